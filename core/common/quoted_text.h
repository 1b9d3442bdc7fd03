#pragma once
// A string in double quotes with its quote, backslash, newline, return and tab escaped (the
// JSON and procman-config forms share these).

#include <cstdio>
#include <string>

namespace evermap {

// `s` quoted. With `escape_controls`, the other control bytes (below 0x20) become \u00XX as
// JSON needs; else they pass through (procman configs, whose parser knows only \n \r \t).
// Other bytes, UTF-8 included, pass through unchanged.
inline std::string quotedText(const std::string& s, bool escape_controls) {
  std::string out = "\"";
  for (unsigned char c : s) {
    switch (c) {
      case '"':
        out += "\\\"";
        break;
      case '\\':
        out += "\\\\";
        break;
      case '\n':
        out += "\\n";
        break;
      case '\r':
        out += "\\r";
        break;
      case '\t':
        out += "\\t";
        break;
      default:
        if (escape_controls && c < 0x20) {
          char buf[8];
          std::snprintf(buf, sizeof(buf), "\\u%04x", c);
          out += buf;
        } else {
          out += static_cast<char>(c);
        }
    }
  }
  return out + "\"";
}

}  // namespace evermap
