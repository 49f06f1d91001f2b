// A small XML well-formedness check for tests of generated SVG: one root element, tags
// nested and closed, attribute values quoted, '&' only in entities, no stray '<'. (No DTDs,
// CDATA or namespaces checks: penumbra writes none.) Header-only; tests only.
#pragma once

#include <cctype>
#include <string>
#include <string_view>
#include <vector>

namespace penumbra::testing {

inline bool xml_entity_ok(std::string_view s, size_t amp, size_t* end) {
  size_t semi = s.find(';', amp);
  if (semi == std::string_view::npos || semi - amp > 10) return false;
  std::string_view name = s.substr(amp + 1, semi - amp - 1);
  bool ok = name == "amp" || name == "lt" || name == "gt" || name == "quot" || name == "apos";
  if (!ok && name.size() >= 2 && name[0] == '#') {
    ok = true;
    bool hex = name[1] == 'x';
    for (size_t i = hex ? 2 : 1; i < name.size(); ++i)
      ok = ok && (hex ? std::isxdigit(static_cast<unsigned char>(name[i])) : std::isdigit(static_cast<unsigned char>(name[i])));
    ok = ok && name.size() > (hex ? 2u : 1u);
  }
  *end = semi + 1;
  return ok;
}

inline bool xml_well_formed(std::string_view s, std::string* problem) {
  auto fail = [&](size_t at, const std::string& what) {
    if (problem) *problem = what + " at offset " + std::to_string(at);
    return false;
  };
  auto is_name = [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == ':' || c == '.'; };
  std::vector<std::string> stack;
  int roots = 0;
  size_t i = 0;
  while (i < s.size()) {
    char c = s[i];
    if (c == '&') {
      size_t end;
      if (!xml_entity_ok(s, i, &end)) return fail(i, "bad entity");
      if (stack.empty()) return fail(i, "text outside the root");
      i = end;
      continue;
    }
    if (c != '<') {
      if (stack.empty() && !std::isspace(static_cast<unsigned char>(c))) return fail(i, "text outside the root");
      ++i;
      continue;
    }
    if (s.compare(i, 5, "<?xml") == 0) {
      if (i != 0) return fail(i, "XML declaration not at the start");
      size_t e = s.find("?>", i);
      if (e == std::string_view::npos) return fail(i, "unterminated declaration");
      i = e + 2;
      continue;
    }
    if (s.compare(i, 4, "<!--") == 0) {
      size_t e = s.find("-->", i);
      if (e == std::string_view::npos) return fail(i, "unterminated comment");
      i = e + 3;
      continue;
    }
    bool closing = i + 1 < s.size() && s[i + 1] == '/';
    size_t p = i + (closing ? 2 : 1);
    size_t name_start = p;
    while (p < s.size() && is_name(s[p])) ++p;
    std::string name(s.substr(name_start, p - name_start));
    if (name.empty()) return fail(i, "'<' without a tag name");
    if (closing) {
      while (p < s.size() && std::isspace(static_cast<unsigned char>(s[p]))) ++p;
      if (p >= s.size() || s[p] != '>') return fail(p, "bad closing tag");
      if (stack.empty() || stack.back() != name) return fail(i, "closing </" + name + "> does not match");
      stack.pop_back();
      i = p + 1;
      continue;
    }
    // Attributes.
    bool self_closing = false;
    while (true) {
      while (p < s.size() && std::isspace(static_cast<unsigned char>(s[p]))) ++p;
      if (p >= s.size()) return fail(i, "unterminated tag");
      if (s[p] == '>') { ++p; break; }
      if (s[p] == '/') {
        if (p + 1 >= s.size() || s[p + 1] != '>') return fail(p, "bad '/' in tag");
        self_closing = true;
        p += 2;
        break;
      }
      size_t a = p;
      while (p < s.size() && is_name(s[p])) ++p;
      if (p == a) return fail(p, "bad attribute name");
      if (p >= s.size() || s[p] != '=') return fail(p, "attribute without '='");
      ++p;
      if (p >= s.size() || (s[p] != '"' && s[p] != '\'')) return fail(p, "unquoted attribute value");
      char q = s[p++];
      while (p < s.size() && s[p] != q) {
        if (s[p] == '<') return fail(p, "'<' in an attribute value");
        if (s[p] == '&') {
          size_t end;
          if (!xml_entity_ok(s, p, &end)) return fail(p, "bad entity in an attribute value");
          p = end;
        } else {
          ++p;
        }
      }
      if (p >= s.size()) return fail(a, "unterminated attribute value");
      ++p;
    }
    if (stack.empty()) {
      if (++roots > 1) return fail(i, "a second root element");
    }
    if (!self_closing) stack.push_back(name);
    i = p;
  }
  if (!stack.empty()) return fail(s.size(), "<" + stack.back() + "> not closed");
  if (roots != 1) return fail(0, "no root element");
  return true;
}

}  // namespace penumbra::testing
