#pragma once
// The names of an enum, written once: name(), parse() with a one-line error listing the
// choices, all(), and `names` for a params::choice field. The enumerators must be 0, 1, 2 ...
// in the order of `names` (the same rule as params::choice).
//
//   const params::EnumTable<MlsMethod>& mlsMethods() {
//     static const params::EnumTable<MlsMethod> t{"MLS method", {"affine", "similarity", "rigid"}};
//     return t;
//   }
#include <string>
#include <utility>
#include <vector>

#include "vellum/core/error.hpp"

namespace vellum::params {

template <class E>
struct EnumTable {
  std::string what;                                ///< for errors: "MLS method"
  std::vector<std::string> names;                  ///< in enum order: what users type and files hold
  std::vector<std::pair<std::string, E>> aliases;  ///< older spellings still read, never written

  EnumTable(std::string what_, std::vector<std::string> names_, std::vector<std::pair<std::string, E>> aliases_ = {})
      : what(std::move(what_)), names(std::move(names_)), aliases(std::move(aliases_)) {}

  const char* name(E e) const {
    const auto i = static_cast<size_t>(e);
    return i < names.size() ? names[i].c_str() : "?";
  }
  /// The enumerator named `text` (a name or an alias); throws vellum::Error
  /// "WHAT: 'text' is not one of a, b, c" otherwise.
  E parse(const std::string& text) const {
    for (size_t i = 0; i < names.size(); ++i)
      if (names[i] == text) return static_cast<E>(i);
    for (const auto& [alias, e] : aliases)
      if (alias == text) return e;
    std::string list;
    for (const auto& n : names) list += (list.empty() ? "" : ", ") + n;
    throw Error(what + ": '" + text + "' is not one of " + list);
  }
  /// Every enumerator, in order.
  std::vector<E> all() const {
    std::vector<E> out;
    for (size_t i = 0; i < names.size(); ++i) out.push_back(static_cast<E>(i));
    return out;
  }
};

}  // namespace vellum::params
