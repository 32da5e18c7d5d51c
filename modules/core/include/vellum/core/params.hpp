#pragma once
// One description per parameter. Each parameter struct of the library keeps its defaults in
// its member initialisers and gets, beside it, a Table: one Field per member with its key,
// label, help, unit and range (or choice names). Validation, the CLI flags, the JSON of
// reports and scenes, the studio's widgets and docs/parameters.md are all generated from
// that table, so nothing about a parameter is written twice.
//
//   const params::Table<MlsParams>& mlsTable() {
//     static const params::Table<MlsParams> t{
//       params::real<MlsParams>("power", &MlsParams::power,
//                               {"MLS power", "n in w = 1/|v - y|^n", "", 0.5, 8}),
//
// A field names its member by pointer to member (&S::x), a nested one with
// params::nested(&S::camera, &Camera::azimuthDeg), or (rarely) any callable returning a
// reference to it.
//     };
//     return t;
//   }
#include <array>
#include <cmath>
#include <functional>
#include <limits>
#include <optional>
#include <string>
#include <type_traits>
#include <vector>

namespace vellum::params {

enum class Kind { Real, Integer, Flag, Choice, Text, Vector };

/// What a field says about itself (everything but how to reach it).
struct Info {
  std::string label;  ///< short, for widgets and docs ("Control scale")
  std::string help;   ///< one sentence
  std::string unit;   ///< "mm", "HU", "voxels", "" (dimensionless)
  double min = -std::numeric_limits<double>::infinity();  ///< Real/Integer, inclusive
  double max = std::numeric_limits<double>::infinity();   ///< Real/Integer, inclusive
};

/// One member of parameter struct S. Numbers, flags and choices travel as double (a choice
/// as its index in `choices`); nullopt means "unset" (std::optional members only). A Vector
/// is three numbers (a colour, a direction), each inside [min, max]; a Text may be limited to
/// `choices` (a name that is not an enum).
template <class S>
struct Field;
template <class S>
Field<S> makeField(std::string key, Info info, Kind kind);

template <class S>
struct Field {
  std::string key;  ///< JSON key; the CLI flag is --key
  Info info;
  Kind kind = Kind::Real;
  bool optional = false;             ///< the member is std::optional: "unset" is allowed
  std::vector<std::string> choices;  ///< Kind::Choice: names, in enum order
  std::function<std::optional<double>(const S&)> get;
  std::function<void(S&, std::optional<double>)> set;
  std::function<std::string(const S&)> getText;          ///< Kind::Text
  std::function<void(S&, const std::string&)> setText;   ///< Kind::Text
  std::function<std::array<double, 3>(const S&)> getVector;         ///< Kind::Vector
  std::function<void(S&, const std::array<double, 3>&)> setVector;  ///< Kind::Vector
};

template <class S>
using Table = std::vector<Field<S>>;

template <class S>
Field<S> makeField(std::string key, Info info, Kind kind) {
  Field<S> f;
  f.key = std::move(key);
  f.info = std::move(info);
  f.kind = kind;
  return f;
}

/// The double closest to the shortest decimal that reads back as `v` (0.3f -> 0.3, not
/// 0.30000001192...): float members print and serialise as written.
double floatValue(float v);

/// A member of a member, for a Field: nested(&RenderSettings::camera, &Camera::azimuthDeg).
template <class... Members>
auto nested(Members... members) {
  return [=](auto& s) -> auto& { return (s .* ... .* members); };
}

namespace detail {
// The member a field is bound to: a pointer to member or a callable returning a reference.
template <class Ref, class T>
decltype(auto) member(const Ref& ref, T& s) {
  if constexpr (std::is_member_object_pointer_v<Ref>) return (s.*ref);
  else return ref(s);
}
template <class T> struct IsOptional : std::false_type {};
template <class T> double asDouble(T v) {
  if constexpr (std::is_same_v<T, float>) return floatValue(v);
  else return static_cast<double>(v);
}
template <class T> struct IsOptional<std::optional<T>> : std::true_type {};

template <class S, class Ref>
Field<S> numeric(Kind kind, std::string key, Ref ref, Info info) {
  using Member = std::remove_cvref_t<decltype(detail::member(ref, std::declval<S&>()))>;
  Field<S> f = makeField<S>(std::move(key), std::move(info), kind);
  f.optional = IsOptional<Member>::value;
  f.get = [ref](const S& s) -> std::optional<double> {
    const auto& m = detail::member(ref, s);
    if constexpr (IsOptional<Member>::value) {
      if (!m) return std::nullopt;
      return detail::asDouble(*m);
    } else {
      return detail::asDouble(m);
    }
  };
  f.set = [ref](S& s, std::optional<double> v) {
    auto& m = detail::member(ref, s);
    if constexpr (IsOptional<Member>::value) {
      using T = typename Member::value_type;
      m = v ? std::optional<T>(static_cast<T>(*v)) : std::nullopt;
    } else if (v) {
      m = static_cast<Member>(*v);
    }
  };
  return f;
}
}  // namespace detail

/// A real number (double or float member, or std::optional of one).
template <class S, class Ref>
Field<S> real(std::string key, Ref ref, Info info) {
  return detail::numeric<S>(Kind::Real, std::move(key), ref, std::move(info));
}
/// An integer (any integral member, or std::optional of one).
template <class S, class Ref>
Field<S> integer(std::string key, Ref ref, Info info) {
  return detail::numeric<S>(Kind::Integer, std::move(key), ref, std::move(info));
}
/// An on/off switch (bool member).
template <class S, class Ref>
Field<S> flag(std::string key, Ref ref, Info info) {
  info.min = 0;
  info.max = 1;
  return detail::numeric<S>(Kind::Flag, std::move(key), ref, std::move(info));
}
/// An enum member whose enumerators are 0, 1, 2 ... in the order of `names`.
template <class S, class Ref>
Field<S> choice(std::string key, Ref ref, std::vector<std::string> names, Info info) {
  using Enum = std::remove_cvref_t<decltype(detail::member(ref, std::declval<S&>()))>;
  Field<S> f = makeField<S>(std::move(key), std::move(info), Kind::Choice);
  f.info.min = 0;
  f.info.max = static_cast<double>(names.size()) - 1;
  f.choices = std::move(names);
  f.get = [ref](const S& s) -> std::optional<double> { return static_cast<double>(static_cast<int>(detail::member(ref, s))); };
  f.set = [ref](S& s, std::optional<double> v) {
    if (v) detail::member(ref, s) = static_cast<Enum>(static_cast<int>(*v));
  };
  return f;
}
/// A string member; with `choices`, only those names are accepted.
template <class S, class Ref>
Field<S> text(std::string key, Ref ref, Info info, std::vector<std::string> choices = {}) {
  Field<S> f = makeField<S>(std::move(key), std::move(info), Kind::Text);
  f.choices = std::move(choices);
  f.getText = [ref](const S& s) { return std::string(detail::member(ref, s)); };
  f.setText = [ref](S& s, const std::string& v) { detail::member(ref, s) = v; };
  return f;
}
/// Three numbers (a std::array<float|double, 3> or a Vec3-like member with operator[]),
/// each inside [info.min, info.max]: colours (0..1) and directions.
template <class S, class Ref>
Field<S> vector(std::string key, Ref ref, Info info) {
  Field<S> f = makeField<S>(std::move(key), std::move(info), Kind::Vector);
  f.getVector = [ref](const S& s) {
    const auto& m = detail::member(ref, s);
    return std::array<double, 3>{detail::asDouble(m[0]), detail::asDouble(m[1]), detail::asDouble(m[2])};
  };
  f.setVector = [ref](S& s, const std::array<double, 3>& v) {
    auto& m = detail::member(ref, s);
    using T = std::remove_cvref_t<decltype(m[0])>;
    for (int i = 0; i < 3; ++i) m[i] = static_cast<T>(v[i]);
  };
  return f;
}

/// The fields of `sub` (the table of a member struct, reached by `ref`) as fields of S, keys
/// prefixed with `prefix`: a struct described once and embedded in the tables that hold it.
template <class S, class Sub, class Ref>
Table<S> embed(const std::string& prefix, Ref ref, const Table<Sub>& sub) {
  Table<S> out;
  for (const Field<Sub>& f : sub) {
    Field<S> e = makeField<S>(prefix + f.key, f.info, f.kind);
    e.optional = f.optional;
    e.choices = f.choices;
    if (f.get) e.get = [ref, g = f.get](const S& s) { return g(detail::member(ref, s)); };
    if (f.set) e.set = [ref, st = f.set](S& s, std::optional<double> v) { st(detail::member(ref, s), v); };
    if (f.getText) e.getText = [ref, g = f.getText](const S& s) { return g(detail::member(ref, s)); };
    if (f.setText) e.setText = [ref, st = f.setText](S& s, const std::string& v) { st(detail::member(ref, s), v); };
    if (f.getVector) e.getVector = [ref, g = f.getVector](const S& s) { return g(detail::member(ref, s)); };
    if (f.setVector)
      e.setVector = [ref, st = f.setVector](S& s, const std::array<double, 3>& v) { st(detail::member(ref, s), v); };
    out.push_back(std::move(e));
  }
  return out;
}

/// The field of `table` with key `key`, or nullptr.
template <class S>
const Field<S>* findField(const Table<S>& table, const std::string& key) {
  for (const auto& f : table)
    if (f.key == key) return &f;
  return nullptr;
}

/// The field's value as users write it: "2.5", "4", "true", "affine", "" (unset).
template <class S>
std::string format(const Field<S>& f, const S& s);
/// Parses `text` (as `format` writes it; "" unsets an optional) into `s` and checks the
/// range. Throws vellum::Error "KEY: problem" naming the accepted values.
template <class S>
void parse(const Field<S>& f, S& s, const std::string& text);
/// Checks every field of `s` against its range; throws vellum::Error naming the first
/// offender, e.g. "control_scale = 0 is outside 1..16".
template <class S>
void validate(const Table<S>& table, const S& s);
/// A Markdown table: key, default (from S{}), range or choices, unit, help.
template <class S>
std::string markdown(const Table<S>& table, const S& defaults = S{});

/// The command-line flag of a key: "control_scale" -> "--control-scale".
std::string cliFlag(const std::string& key);
/// " --key value" for every field of `s` (switches as --key=true|false; unset optionals left
/// out; keys in `skip` too): how the studio writes the CLI command for what it shows.
template <class S>
std::string cliArguments(const Table<S>& table, const S& s, const std::vector<std::string>& skip = {});

// Non-template cores of the above (params.cpp).
std::string formatNumber(Kind kind, double v, const std::vector<std::string>& choices);
double parseNumber(const std::string& key, Kind kind, const Info& info,
                   const std::vector<std::string>& choices, const std::string& text);
void checkRange(const std::string& key, Kind kind, const Info& info, const std::vector<std::string>& choices,
                double v);
std::string rangeText(Kind kind, const Info& info, const std::vector<std::string>& choices);
std::string markdownRow(const std::string& key, const std::string& defaultText, const std::string& range,
                        const Info& info);
std::string markdownHeader();
std::string formatVector(const std::array<double, 3>& v);
std::array<double, 3> parseVector(const std::string& key, const Info& info, const std::string& text);
void checkVector(const std::string& key, const Info& info, const std::array<double, 3>& v);
void checkTextChoice(const std::string& key, const std::vector<std::string>& choices, const std::string& text);

template <class S>
std::string format(const Field<S>& f, const S& s) {
  if (f.kind == Kind::Text) return f.getText(s);
  if (f.kind == Kind::Vector) return formatVector(f.getVector(s));
  const auto v = f.get(s);
  return v ? formatNumber(f.kind, *v, f.choices) : std::string();
}

template <class S>
void parse(const Field<S>& f, S& s, const std::string& text) {
  if (f.kind == Kind::Text) {
    checkTextChoice(f.key, f.choices, text);
    return f.setText(s, text);
  }
  if (f.kind == Kind::Vector) return f.setVector(s, parseVector(f.key, f.info, text));
  if (text.empty() && f.optional) return f.set(s, std::nullopt);
  f.set(s, parseNumber(f.key, f.kind, f.info, f.choices, text));
}

template <class S>
std::string cliArguments(const Table<S>& table, const S& s, const std::vector<std::string>& skip) {
  std::string out;
  for (const auto& f : table) {
    bool skipped = false;
    for (const auto& k : skip) skipped = skipped || k == f.key;
    const std::string v = format(f, s);
    if (skipped || (v.empty() && f.kind != Kind::Text)) continue;
    out += f.kind == Kind::Flag ? " " + cliFlag(f.key) + "=" + v : " " + cliFlag(f.key) + " " + v;
  }
  return out;
}

template <class S>
void validate(const Table<S>& table, const S& s) {
  for (const auto& f : table) {
    if (f.kind == Kind::Text) checkTextChoice(f.key, f.choices, f.getText(s));
    else if (f.kind == Kind::Vector) checkVector(f.key, f.info, f.getVector(s));
    else if (const auto v = f.get(s)) checkRange(f.key, f.kind, f.info, f.choices, *v);
  }
}

template <class S>
std::string markdown(const Table<S>& table, const S& defaults) {
  std::string out = markdownHeader();
  for (const auto& f : table) {
    const std::string d = format(f, defaults);
    out += markdownRow(f.key, d.empty() ? "unset" : d, rangeText(f.kind, f.info, f.choices), f.info);
  }
  return out;
}

}  // namespace vellum::params
