#pragma once
// JSON of a parameter struct through its table (vellum/core/params.hpp): reports, scene files
// and style files write and read parameters with the same keys, ranges and choice names as
// the CLI flags. Header-only; the includer links nlohmann_json.
#include <nlohmann/json.hpp>

#include <string>

#include "vellum/core/error.hpp"
#include "vellum/core/params.hpp"

namespace vellum::params {

/// {"key": value, ...}: numbers as numbers, switches as booleans, choices as names; unset
/// optionals are left out.
template <class S>
nlohmann::json toJson(const Table<S>& table, const S& s) {
  nlohmann::json j = nlohmann::json::object();
  for (const auto& f : table) {
    if (f.kind == Kind::Text) {
      j[f.key] = f.getText(s);
      continue;
    }
    if (f.kind == Kind::Vector) {
      const auto v = f.getVector(s);
      j[f.key] = nlohmann::json::array({v[0], v[1], v[2]});
      continue;
    }
    const auto v = f.get(s);
    if (!v) continue;
    if (f.kind == Kind::Flag) j[f.key] = *v != 0;
    else if (f.kind == Kind::Choice) j[f.key] = formatNumber(f.kind, *v, f.choices);
    else if (f.kind == Kind::Integer) j[f.key] = static_cast<long long>(*v);
    else j[f.key] = *v;
  }
  return j;
}

/// Sets one field from its JSON value; throws vellum::Error "KEY: problem" (or "KEY = V is
/// outside RANGE") for a wrong type or a value out of range.
template <class S>
void setFromJson(const Field<S>& f, const nlohmann::json& v, S& s) {
  if (v.is_null() && f.optional) f.set(s, std::nullopt);
  else if (f.kind == Kind::Flag && v.is_boolean()) f.set(s, v.get<bool>() ? 1.0 : 0.0);
  else if ((f.kind == Kind::Choice || f.kind == Kind::Text) && v.is_string()) parse(f, s, v.get<std::string>());
  else if ((f.kind == Kind::Real || f.kind == Kind::Integer) && v.is_number()) parse(f, s, v.dump());
  else if (f.kind == Kind::Vector && v.is_array() && v.size() == 3 && v[0].is_number() && v[1].is_number() &&
           v[2].is_number())
    parse(f, s, v[0].dump() + " " + v[1].dump() + " " + v[2].dump());
  else
    throw Error(f.key + ": wrong type (" + std::string(v.type_name()) +
                (f.kind == Kind::Vector ? "; expected [x, y, z])" : ")"));
}

/// Reads the keys of `table` present in `j` into `s` (absent keys keep their values; null
/// unsets an optional). Throws vellum::Error "WHERE: key: problem" for a wrong type, a value
/// out of range or an unknown choice; unknown keys are refused too (a typo must not pass
/// silently).
template <class S>
void fromJson(const Table<S>& table, const nlohmann::json& j, S& s, const std::string& where) {
  if (!j.is_object()) throw Error(where + ": expected an object of parameters");
  for (auto it = j.begin(); it != j.end(); ++it) {
    const Field<S>* f = findField(table, it.key());
    if (!f) throw Error(where + ": unknown parameter '" + it.key() + "'");
    try {
      setFromJson(*f, it.value(), s);
    } catch (const Error& e) {
      throw Error(where + ": " + e.what());
    }
  }
}

}  // namespace vellum::params
