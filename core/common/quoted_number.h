#pragma once
// A bad input value as an error message quotes it: numberText (core/common/number_text.h),
// but a NaN is "nan" whatever its sign ("-nan" from a YAML ".nan" reads as a typo).

#include <cmath>
#include <string>

#include "core/common/number_text.h"

namespace evermap {

inline std::string quotedNumberText(double v) { return std::isnan(v) ? "nan" : numberText(v); }

}  // namespace evermap
