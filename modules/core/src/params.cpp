#include "vellum/core/params.hpp"

#include <charconv>
#include <cmath>

#include "vellum/core/error.hpp"

namespace vellum::params {
namespace {

std::string shortest(double v) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

std::string joined(const std::vector<std::string>& names, const char* sep) {
  std::string out;
  for (size_t i = 0; i < names.size(); ++i) out += (i ? sep : "") + names[i];
  return out;
}

}  // namespace

double floatValue(float v) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  double d = 0;
  std::from_chars(buf, r.ptr, d);
  return d;
}

std::string cliFlag(const std::string& key) {
  std::string flag = "--" + key;
  for (char& c : flag)
    if (c == '_') c = '-';
  return flag;
}

std::string formatNumber(Kind kind, double v, const std::vector<std::string>& choices) {
  switch (kind) {
    case Kind::Flag: return v != 0 ? "true" : "false";
    case Kind::Choice: {
      const auto i = static_cast<size_t>(v);
      return i < choices.size() ? choices[i] : shortest(v);
    }
    case Kind::Integer: return std::to_string(static_cast<long long>(v));
    default: return shortest(v);
  }
}

double parseNumber(const std::string& key, Kind kind, const Info& info, const std::vector<std::string>& choices,
                   const std::string& text) {
  double v = 0;
  if (kind == Kind::Flag) {
    if (text == "true" || text == "1" || text == "on" || text == "yes") v = 1;
    else if (text == "false" || text == "0" || text == "off" || text == "no") v = 0;
    else throw Error(key + ": '" + text + "' is not true or false");
  } else if (kind == Kind::Choice) {
    size_t i = 0;
    while (i < choices.size() && choices[i] != text) ++i;
    if (i == choices.size()) throw Error(key + ": '" + text + "' is not one of " + joined(choices, ", "));
    v = static_cast<double>(i);
  } else {
    const char* end = text.data() + text.size();
    const auto r = std::from_chars(text.data(), end, v);
    if (text.empty() || r.ec != std::errc() || r.ptr != end || !std::isfinite(v))
      throw Error(key + ": '" + text + "' is not a number");
    if (kind == Kind::Integer && v != std::floor(v)) throw Error(key + ": '" + text + "' is not a whole number");
  }
  checkRange(key, kind, info, choices, v);
  return v;
}

void checkRange(const std::string& key, Kind kind, const Info& info, const std::vector<std::string>& choices,
                double v) {
  if (!(v >= info.min && v <= info.max))
    throw Error(key + " = " + formatNumber(kind, v, choices) + " is outside " + rangeText(kind, info, choices));
}

std::string formatVector(const std::array<double, 3>& v) {
  return shortest(v[0]) + " " + shortest(v[1]) + " " + shortest(v[2]);
}

std::array<double, 3> parseVector(const std::string& key, const Info& info, const std::string& text) {
  // "r g b", "r,g,b" or "[r, g, b]"
  std::string t = text;
  for (char& c : t)
    if (c == ',' || c == '[' || c == ']') c = ' ';
  std::array<double, 3> v{};
  size_t at = 0, n = 0;
  while (true) {
    while (at < t.size() && t[at] == ' ') ++at;
    if (at >= t.size()) break;
    const size_t end = t.find(' ', at);
    const std::string token = t.substr(at, end == std::string::npos ? std::string::npos : end - at);
    if (n == 3) throw Error(key + ": '" + text + "' is not three numbers");
    v[n++] = parseNumber(key, Kind::Real, {"", "", "", -INFINITY, INFINITY}, {}, token);
    if (end == std::string::npos) break;
    at = end;
  }
  if (n != 3) throw Error(key + ": '" + text + "' is not three numbers");
  checkVector(key, info, v);
  return v;
}

void checkVector(const std::string& key, const Info& info, const std::array<double, 3>& v) {
  for (double x : v)
    if (!(x >= info.min && x <= info.max))
      throw Error(key + " = " + formatVector(v) + " is outside " + rangeText(Kind::Vector, info, {}));
}

void checkTextChoice(const std::string& key, const std::vector<std::string>& choices, const std::string& text) {
  if (choices.empty()) return;
  for (const auto& c : choices)
    if (c == text) return;
  throw Error(key + ": '" + text + "' is not one of " + joined(choices, ", "));
}

std::string rangeText(Kind kind, const Info& info, const std::vector<std::string>& choices) {
  if (kind == Kind::Choice || (kind == Kind::Text && !choices.empty())) return joined(choices, " | ");
  if (kind == Kind::Flag) return "true | false";
  if (kind == Kind::Text) return "text";
  if (kind == Kind::Vector) return "3 numbers, each " + rangeText(Kind::Real, info, {});
  const bool lo = std::isfinite(info.min), hi = std::isfinite(info.max);
  if (lo && hi) return shortest(info.min) + ".." + shortest(info.max);
  if (lo) return "≥ " + shortest(info.min);
  if (hi) return "≤ " + shortest(info.max);
  return "any";
}

std::string markdownHeader() { return "| key | default | range | unit | meaning |\n|---|---|---|---|---|\n"; }

std::string markdownRow(const std::string& key, const std::string& defaultText, const std::string& range,
                        const Info& info) {
  const auto cell = [](const std::string& text) {  // a '|' would end the cell
    std::string out;
    for (char c : text) out += c == '|' ? std::string("\\|") : std::string(1, c);
    return out;
  };
  return "| `" + key + "` | " + cell(defaultText) + " | " + cell(range) + " | " + cell(info.unit) + " | " +
         cell(info.label + ": " + info.help) + " |\n";
}

}  // namespace vellum::params
