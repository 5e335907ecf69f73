// The one definition of the options (arap::option_specs()): defaults within
// their limits, the limits enforced by check_options() and named in its
// messages, every choice round-tripping through its name.
#include <gtest/gtest.h>

#include <cmath>
#include <set>

#include "arap/errors.h"
#include "arap/options.h"

namespace {

std::string refusal(const arap::Options& o) {
  try {
    arap::check_options(o);
  } catch (const arap::Error& e) {
    EXPECT_EQ(e.code(), arap::ErrorCode::InvalidInput);
    return e.what();
  }
  return "";
}

TEST(Options, DefaultsAreWithinTheLimitsAndNamesAreUnique) {
  EXPECT_EQ(refusal(arap::Options()), "");
  std::set<std::string> names;
  for (const arap::OptionSpec& spec : arap::option_specs()) {
    EXPECT_TRUE(names.insert(spec.name).second) << spec.name;
    EXPECT_EQ(&arap::option_spec(spec.name), &spec);
  }
  EXPECT_TRUE(names.count("max_iterations") && names.count("anderson_window") && names.count("method"));
  EXPECT_THROW(arap::option_spec("iterations"), arap::Error);
}

TEST(Options, NumbersAreCheckedAtTheirLimitsWithMessagesNamingThem) {
  for (const arap::OptionSpec& spec : arap::option_specs()) {
    if (spec.kind == arap::OptionKind::Choice) continue;
    SCOPED_TRACE(spec.name);
    const double step = spec.kind == arap::OptionKind::Integer ? 1 : 1e-9 * std::max(1.0, spec.max);
    arap::Options o;
    spec.set_number(o, spec.min);
    EXPECT_EQ(refusal(o), "");
    EXPECT_EQ(spec.get_number(o), spec.min);
    spec.set_number(o, spec.min - step);
    const std::string below = refusal(o);
    EXPECT_EQ(below.rfind(spec.name, 0), 0u) << below;
    EXPECT_NE(below.find(arap::option_limits(spec)), std::string::npos) << below;
    if (std::isfinite(spec.max)) {
      spec.set_number(o, spec.max);
      EXPECT_EQ(refusal(o), "");
      spec.set_number(o, spec.max + step);
      EXPECT_NE(refusal(o), "");
    } else {
      spec.set_number(o, std::numeric_limits<double>::infinity());
      EXPECT_NE(refusal(o), "");
    }
    if (spec.kind == arap::OptionKind::Real) {
      spec.set_number(o, std::nan(""));
      EXPECT_NE(refusal(o), "");
    }
  }
}

TEST(Options, ChoicesRoundTripAndUnknownNamesAreRefused) {
  for (const arap::OptionSpec& spec : arap::option_specs()) {
    if (spec.kind != arap::OptionKind::Choice) continue;
    SCOPED_TRACE(spec.name);
    for (const std::string& choice : spec.choices) {
      arap::Options o;
      o.volume = arap::Volume::None;  // the one volume mode method anderson accepts
      spec.set_choice(o, choice);
      EXPECT_EQ(spec.get_choice(o), choice);
      EXPECT_EQ(refusal(o), "");
    }
    arap::Options o;
    EXPECT_THROW(spec.set_choice(o, "sideways"), arap::Error);
  }
  arap::Options o;
  o.cold_start = arap::InitialGuess::WarmStart;  // a warm start needs a cold one to fall back to
  EXPECT_EQ(refusal(o), "cold_start must be naive, laplacian or differential, not warm");
  EXPECT_EQ(arap::option_limits(arap::option_spec("anderson_window")), "an integer between 0 and 20");
  EXPECT_EQ(arap::option_limits(arap::option_spec("time_budget_ms")), "a finite number >= 0");
}

}  // namespace
