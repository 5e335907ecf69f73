#include "arap/io/numbers.h"

#include <charconv>
#include <cmath>

namespace arap::io {

namespace {

// The token without one leading '+' (from_chars takes '-' only).
std::string_view unsigned_plus(std::string_view t) {
  if (t.size() > 1 && t[0] == '+' && t[1] != '-' && t[1] != '+') t.remove_prefix(1);
  return t;
}

}  // namespace

bool parse_integer(std::string_view token, long long& out) {
  token = unsigned_plus(token);
  const char* end = token.data() + token.size();
  const auto r = std::from_chars(token.data(), end, out);
  return !token.empty() && r.ec == std::errc() && r.ptr == end;
}

bool parse_finite(std::string_view token, double& out) {
  token = unsigned_plus(token);
  const char* end = token.data() + token.size();
  const auto r = std::from_chars(token.data(), end, out, std::chars_format::general);
  return !token.empty() && r.ec == std::errc() && r.ptr == end && std::isfinite(out);
}

}  // namespace arap::io
