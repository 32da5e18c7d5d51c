#pragma once
// Small GDCM helpers for the dicom_*.cpp files (includes GDCM: never include from a public
// header or from anything outside io/src/dicom_*.cpp).
#include <gdcmDataElement.h>
#include <gdcmDataSet.h>
#include <gdcmSequenceOfItems.h>
#include <gdcmTag.h>
#include <gdcmTrace.h>

#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <optional>
#include <string>
#include <vector>

namespace vellum::io::detail::dicom {

/// GDCM prints parser complaints to stderr; the loader reports problems itself.
inline void quietGdcm() {
  static const bool once = [] {
    gdcm::Trace::SetDebug(false);
    gdcm::Trace::SetWarning(false);
    gdcm::Trace::SetError(false);
    return true;
  }();
  (void)once;
}

/// Raw bytes of an element (empty when absent, empty or a sequence).
inline std::string rawValue(const gdcm::DataSet& ds, const gdcm::Tag& tag) {
  if (!ds.FindDataElement(tag)) return {};
  const gdcm::DataElement& de = ds.GetDataElement(tag);
  const gdcm::ByteValue* bv = de.GetByteValue();
  if (!bv || !bv->GetPointer()) return {};
  return std::string(bv->GetPointer(), bv->GetLength());
}

/// Text value with DICOM padding (spaces, NULs) removed at both ends.
inline std::string stringValue(const gdcm::DataSet& ds, const gdcm::Tag& tag) {
  std::string s = rawValue(ds, tag);
  const auto isPad = [](char c) { return c == ' ' || c == '\0' || c == '\t' || c == '\r' || c == '\n'; };
  size_t b = 0, e = s.size();
  while (b < e && isPad(s[b])) ++b;
  while (e > b && isPad(s[e - 1])) --e;
  return s.substr(b, e - b);
}

/// Backslash-separated decimal (DS/IS) values; nullopt when absent or empty. A part that is
/// not a finite number reads as NaN, so callers can refuse it (rather than mistake it for an
/// absent value).
inline std::optional<std::vector<double>> numbers(const gdcm::DataSet& ds, const gdcm::Tag& tag) {
  const std::string s = stringValue(ds, tag);
  if (s.empty()) return std::nullopt;
  std::vector<double> out;
  size_t start = 0;
  for (;;) {
    size_t end = s.find('\\', start);
    if (end == std::string::npos) end = s.size();
    // from_chars: locale-independent (DICOM always uses '.').
    const char* p = s.data() + start;
    const char* e = s.data() + end;
    while (p < e && *p == ' ') ++p;
    while (e > p && (e[-1] == ' ' || e[-1] == '\0')) --e;
    if (p < e && *p == '+') ++p;
    double v = 0;
    const auto [stop, ec] = std::from_chars(p, e, v);
    if (ec != std::errc() || stop != e || p == e || !std::isfinite(v))
      v = std::numeric_limits<double>::quiet_NaN();
    out.push_back(v);
    if (end == s.size()) break;
    start = end + 1;
  }
  return out;
}

inline std::optional<double> number(const gdcm::DataSet& ds, const gdcm::Tag& tag) {
  auto v = numbers(ds, tag);
  if (!v || v->empty()) return std::nullopt;
  return (*v)[0];
}

/// Binary US value (little-endian as GDCM holds it in memory for LE transfer syntaxes).
inline std::optional<uint16_t> ushortValue(const gdcm::DataSet& ds, const gdcm::Tag& tag) {
  const std::string s = rawValue(ds, tag);
  if (s.size() < 2) return std::nullopt;
  return static_cast<uint16_t>(static_cast<uint8_t>(s[0]) | (static_cast<uint8_t>(s[1]) << 8));
}

/// Items of a sequence (null when absent). Keep the pointer alive while using the items:
/// GDCM may build the sequence on the fly (e.g. from an UN element).
inline gdcm::SmartPointer<gdcm::SequenceOfItems> sequence(const gdcm::DataSet& ds,
                                                         const gdcm::Tag& tag) {
  if (!ds.FindDataElement(tag)) return nullptr;
  return ds.GetDataElement(tag).GetValueAsSQ();
}

/// Copy of the first item's nested data set of a sequence (nullopt when absent or empty).
inline std::optional<gdcm::DataSet> firstItem(const gdcm::DataSet& ds, const gdcm::Tag& tag) {
  gdcm::SmartPointer<gdcm::SequenceOfItems> sq = sequence(ds, tag);
  if (!sq || sq->GetNumberOfItems() < 1) return std::nullopt;
  return sq->GetItem(1).GetNestedDataSet();
}

}  // namespace vellum::io::detail::dicom
