// Numbers in files and on command lines: whole tokens parsed with
// std::from_chars (no locale, no leading blanks, nothing left over; one
// leading '+' is allowed, as strtod allowed it).
#pragma once

#include <string_view>

namespace arap::io {

// A decimal integer (optional sign) that fits a long long.
bool parse_integer(std::string_view token, long long& out);

// A finite decimal number ("1", "-0.5", "2.5e-3"; no hexadecimal, no inf or nan).
bool parse_finite(std::string_view token, double& out);

}  // namespace arap::io
