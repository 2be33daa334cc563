// A check of TOML text before toml++ parses it. toml++ 3.3.0 (Debian bookworm) reaches
// __builtin_unreachable, i.e. undefined behaviour, on some non-ASCII characters where it tests
// for whitespace (upstream marzer/tomlplusplus issues 190 and 295, fixed after 3.3.0; found here
// by tests/fuzz). edgefuse's TOML files (camera.toml, rig.toml, hal.toml, board.toml,
// edgefused.toml and the localiser's) need no such character outside comments, so every TOML
// reader refuses non-ASCII bytes anywhere else, naming the line. Comments may hold any UTF-8:
// toml++ only looks for the line end there; so may a leading byte order mark. Header-only, no
// heap: shared by the runtime configuration (config_toml), the formats library (tools/formats) and
// the tools; namespace edgefuse::io, that of the TOML readers that call it.
#pragma once

#include <cstddef>
#include <string_view>

namespace edgefuse::io {

//! \param text a TOML document
//! \return 0 when every byte outside comments is ASCII, else the (1-based) line of the first
//!         non-ASCII byte outside a comment
inline unsigned toml_non_ascii_line(std::string_view text) {
  enum class In { kCode, kComment, kBasic, kLiteral, kMultiBasic, kMultiLiteral } in = In::kCode;
  unsigned line = 1;
  const size_t n = text.size();
  auto triple = [&](size_t i, char q) { return i + 2 < n && text[i] == q && text[i + 1] == q && text[i + 2] == q; };
  // A UTF-8 byte order mark (editors on Windows write one) is skipped, as toml++ does.
  const size_t start = text.substr(0, 3) == std::string_view("\xEF\xBB\xBF", 3) ? 3 : 0;
  for (size_t i = start; i < n; ++i) {
    const unsigned char c = static_cast<unsigned char>(text[i]);
    if (c == '\n') {
      ++line;
      if (in != In::kMultiBasic && in != In::kMultiLiteral) in = In::kCode;  // comments and one-line strings end
      continue;
    }
    if (in == In::kComment) continue;
    if (c >= 0x80) return line;
    switch (in) {
      case In::kCode:
        if (c == '#') {
          in = In::kComment;
        } else if (c == '"') {
          in = triple(i, '"') ? In::kMultiBasic : In::kBasic;
          if (in == In::kMultiBasic) i += 2;
        } else if (c == '\'') {
          in = triple(i, '\'') ? In::kMultiLiteral : In::kLiteral;
          if (in == In::kMultiLiteral) i += 2;
        }
        break;
      case In::kBasic:
      case In::kMultiBasic:
        if (c == '\\' && i + 1 < n && (text[i + 1] == '"' || text[i + 1] == '\\')) {
          ++i;  // an escaped quote or backslash does not end the string
        } else if (in == In::kBasic ? c == '"' : triple(i, '"')) {
          if (in == In::kMultiBasic) i += 2;
          in = In::kCode;
        }
        break;
      case In::kLiteral:
        if (c == '\'') in = In::kCode;
        break;
      case In::kMultiLiteral:
        if (triple(i, '\'')) {
          i += 2;
          in = In::kCode;
        }
        break;
      case In::kComment:
        break;
    }
  }
  return 0;
}

//! The refusal of a file toml_non_ascii_line() found a line in.
inline const char* toml_non_ascii_reason() {
  return "a non-ASCII character outside a comment (these files are ASCII; comments may hold any UTF-8)";
}

}  // namespace edgefuse::io
