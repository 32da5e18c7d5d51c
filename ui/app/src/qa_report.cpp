// The report of a `vellum qa` run, made from the case folders' result.json files: JUnit XML
// for CI servers, one self-contained HTML page (pictures embedded as base64 PNG) and
// summary.json.
#include <fstream>
#include <iomanip>
#include <sstream>

#include "vellum/app/outputs.hpp"
#include "vellum/app/qa.hpp"
#include "vellum/core/error.hpp"
#include "vellum/core/json_input.hpp"
#include "vellum/io/atomic_file.hpp"
#include "vellum/io/output_policy.hpp"

namespace vellum::app {
namespace fs = std::filesystem;

namespace {

const char kSnakefile[] =
#include "qa_snakefile.inc"
    ;

std::string readBytes(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
}

void writeText(const std::string& text, const fs::path& path) {
  io::writeAtomically(path, [&](const fs::path& tmp) {
    std::ofstream f(tmp, std::ios::binary);
    f << text;
    f.close();
    if (!f) throw FileError(path, "cannot write");
  });
}

std::string base64(const std::string& in) {
  static const char* t = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((in.size() + 2) / 3 * 4);
  for (size_t i = 0; i < in.size(); i += 3) {
    const uint32_t n = (uint32_t(uint8_t(in[i])) << 16) | (i + 1 < in.size() ? uint32_t(uint8_t(in[i + 1])) << 8 : 0) |
                       (i + 2 < in.size() ? uint32_t(uint8_t(in[i + 2])) : 0);
    out += t[(n >> 18) & 63];
    out += t[(n >> 12) & 63];
    out += i + 1 < in.size() ? t[(n >> 6) & 63] : '=';
    out += i + 2 < in.size() ? t[n & 63] : '=';
  }
  return out;
}

/// Escapes text for XML and HTML (attributes and content).
std::string esc(const std::string& s) {
  std::string o;
  for (char c : s) {
    switch (c) {
      case '&': o += "&amp;"; break;
      case '<': o += "&lt;"; break;
      case '>': o += "&gt;"; break;
      case '"': o += "&quot;"; break;
      case '\'': o += "&apos;"; break;
      default:
        // XML 1.0 allows no control characters but tab, newline, carriage return.
        if (static_cast<unsigned char>(c) < 0x20 && c != '\t' && c != '\n' && c != '\r') o += '?';
        else o += c;
    }
  }
  return o;
}

std::string fixed(double v, int digits) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(digits) << v;
  return s.str();
}

std::string number(const nlohmann::json& v, int digits = 4) {
  if (v.is_null()) return "∞";
  if (!v.is_number()) return esc(v.dump());
  std::ostringstream s;
  s << std::setprecision(digits) << v.get<double>();
  return s.str();
}

/// The numbers of one comparison as a small HTML table.
std::string compareNumbers(const nlohmann::json& c) {
  std::string h;
  if (c.contains("labels")) {
    h += "<table class=n><tr><th>id</th><th>Dice</th><th>Jaccard</th><th>HD95 mm</th><th>ASSD mm</th><th>volume Δ %</th></tr>";
    for (const auto& m : c["labels"])
      h += "<tr><td>" + (m["id"].get<int>() ? std::to_string(m["id"].get<int>()) : std::string("ids")) + "</td><td>" + number(m["dice"], 6) + "</td><td>" +
           number(m["jaccard"], 6) + "</td><td>" + number(m["hd95_mm"]) + "</td><td>" + number(m["assd_mm"]) +
           "</td><td>" + number(m["volume_difference_percent"]) + "</td></tr>";
    h += "</table>";
  }
  if (c.contains("image")) {
    const auto& m = c["image"];
    h += "<table class=n><tr><th>max</th><th>mean</th><th>p" + number(m["percentile"]) +
         "</th><th>differing px</th><th>PSNR dB</th><th>SSIM</th></tr><tr><td>" + number(m["max_difference"]) +
         "</td><td>" + number(m["mean_difference"]) + "</td><td>" + number(m["percentile_difference"]) + "</td><td>" +
         std::to_string(m["differing_pixels"].get<int64_t>()) + " (" + number(m["differing_percent"], 3) +
         "%)</td><td>" + number(m["psnr_db"]) + "</td><td>" + number(m["ssim"], 6) + "</td></tr></table>";
  }
  if (c.contains("volume") && c["volume"].contains("max_abs_difference")) {
    const auto& m = c["volume"];
    const std::string unit = m["unit"].get<std::string>();
    h += "<table class=n><tr><th>geometry</th><th>max |Δ| " + unit + "</th><th>mean |Δ| " + unit +
         "</th><th>differing voxels</th></tr><tr><td>" + (m["geometry_equal"].get<bool>() ? "equal" : "differs") +
         "</td><td>" + number(m["max_abs_difference"]) + "</td><td>" + number(m["mean_abs_difference"]) + "</td><td>" +
         std::to_string(m["differing_voxels"].get<int64_t>()) + " (" + number(m["differing_percent"], 3) +
         "%)</td></tr></table>";
  }
  return h;
}

std::string img(const fs::path& png, const std::string& caption) {
  if (!fs::exists(png)) return {};
  return "<figure><img src=\"data:image/png;base64," + base64(readBytes(png)) + "\" alt=\"" + esc(caption) +
         "\"><figcaption>" + esc(caption) + "</figcaption></figure>";
}

const char kStyle[] = R"css(
body{font:14px/1.4 system-ui,sans-serif;margin:24px;color:#222;max-width:1200px}
h1{font-size:22px;margin:0 0 4px} h2{font-size:17px;margin:28px 0 6px;border-top:1px solid #ddd;padding-top:14px}
.meta{color:#666;margin-bottom:14px} .pass{color:#fff;background:#2e7d32} .fail{color:#fff;background:#c62828}
.badge{padding:1px 8px;border-radius:9px;font-weight:600;font-size:12px}
table{border-collapse:collapse;margin:6px 0} td,th{border:1px solid #ddd;padding:3px 8px;text-align:left;vertical-align:top}
th{background:#f4f4f4;font-weight:600} table.n td{font-variant-numeric:tabular-nums}
code{font-size:12px;background:#f6f6f6;padding:1px 4px;border-radius:3px;word-break:break-all}
.tri{display:flex;gap:10px;flex-wrap:wrap} figure{margin:0} figcaption{font-size:12px;color:#666;text-align:center}
.tri img{width:220px;height:auto;image-rendering:pixelated;border:1px solid #ccc;background:#000}
pre{background:#f6f6f6;padding:8px;font-size:12px;overflow-x:auto;max-height:240px}
.failure{color:#c62828}
)css";

}  // namespace

const char* qaSnakefile() { return kSnakefile; }

QaSummary writeQaReport(const fs::path& out) {
  io::checkFolderOutput(out, io::FolderKind::Qa);
  if (!fs::exists(out / io::folderMarkerName(io::FolderKind::Qa)))
    throw FileError(out, "is not a `vellum qa` run folder (no " + io::folderMarkerName(io::FolderKind::Qa) + ")");
  const nlohmann::json run = readJsonFile(out / "qa-run.json", 1 << 20, "QA run file");
  const std::string suite = run.value("name", std::string("vellum qa"));
  std::vector<nlohmann::json> results;
  QaSummary sum;
  for (const auto& name : run["cases"]) {
    const fs::path file = qaCaseFolder(out, name.get<std::string>()) / "result.json";
    nlohmann::json r;
    if (fs::exists(file)) {
      try {
        r = readJsonFile(file, 64u << 20, "QA case result");
      } catch (const Error& e) {
        r = {{"name", name}, {"pass", false}, {"failures", {std::string(e.what())}}};
      }
    } else {
      r = {{"name", name}, {"pass", false},
           {"failures", {"no result: the case runner did not finish (see logs/" + name.get<std::string>() + ".txt)"}}};
    }
    ++sum.cases;
    sum.failures += !r.value("pass", false);
    sum.seconds += r.value("seconds", 0.0);
    results.push_back(std::move(r));
  }
  // JUnit XML: one testsuite, one testcase per case, a <failure> per failing case.
  std::ostringstream x;
  x << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<testsuites name=\"vellum qa\" tests=\"" << sum.cases
    << "\" failures=\"" << sum.failures << "\" errors=\"0\" time=\"" << fixed(sum.seconds, 3) << "\">\n"
    << "  <testsuite name=\"" << esc(suite) << "\" tests=\"" << sum.cases << "\" failures=\"" << sum.failures
    << "\" errors=\"0\" skipped=\"0\" time=\"" << fixed(sum.seconds, 3) << "\">\n";
  for (const auto& r : results) {
    x << "    <testcase classname=\"vellum.qa." << esc(suite) << "\" name=\"" << esc(r["name"].get<std::string>())
      << "\" time=\"" << fixed(r.value("seconds", 0.0), 3) << "\">\n";
    if (!r.value("pass", false)) {
      std::string all;
      for (const auto& f : r["failures"]) all += f.get<std::string>() + "\n";
      x << "      <failure message=\"" << esc(r["failures"].empty() ? "failed" : r["failures"][0].get<std::string>())
        << "\" type=\"regression\">" << esc(all) << "</failure>\n";
      if (r.contains("log_tail")) x << "      <system-out>" << esc(r["log_tail"].get<std::string>()) << "</system-out>\n";
    }
    x << "    </testcase>\n";
  }
  x << "  </testsuite>\n</testsuites>\n";

  // HTML: a summary table, then each case with its commands, checks and pictures.
  std::ostringstream h;
  h << "<!DOCTYPE html>\n<html lang=en><head><meta charset=utf-8><title>" << esc(suite)
    << " — Vellum QA</title><style>" << kStyle << "</style></head><body>\n<h1>" << esc(suite) << "</h1>\n<div class=meta>"
    << sum.cases - sum.failures << " of " << sum.cases << " cases pass · " << fixed(sum.seconds, 1)
    << " s of commands · Vellum " << esc(run.value("vellum_version", std::string("?"))) << " · started "
    << esc(run.value("started_utc", std::string("?"))) << " · manifest <code>" << esc(run.value("manifest", std::string()))
    << "</code>" << (run.value("update_baselines", false) ? " · <b>baselines updated</b>" : "") << "</div>\n";
  h << "<table><tr><th>case</th><th>result</th><th>time s</th><th>peak MiB</th><th>failures</th></tr>\n";
  for (const auto& r : results) {
    const std::string n = r["name"].get<std::string>();
    const bool pass = r.value("pass", false);
    h << "<tr><td><a href=\"#" << esc(n) << "\">" << esc(n) << "</a></td><td><span class=\"badge "
      << (pass ? "pass\">PASS" : "fail\">FAIL") << "</span></td><td>" << fixed(r.value("seconds", 0.0), 2) << "</td><td>"
      << fixed(r.value("max_rss_mb", 0.0), 0) << "</td><td class=failure>";
    for (const auto& f : r["failures"]) h << esc(f.get<std::string>()) << "<br>";
    h << "</td></tr>\n";
  }
  h << "</table>\n";
  for (const auto& r : results) {
    const std::string n = r["name"].get<std::string>();
    const fs::path dir = qaCaseFolder(out, n);
    const bool pass = r.value("pass", false);
    h << "<h2 id=\"" << esc(n) << "\">" << esc(n) << " <span class=\"badge " << (pass ? "pass\">PASS" : "fail\">FAIL")
      << "</span></h2>\n";
    if (r.contains("commands")) {
      h << "<table><tr><th>command</th><th>exit</th><th>wall s</th><th>CPU s</th><th>peak MiB</th></tr>";
      for (const auto& c : r["commands"])
        h << "<tr><td><code>" << esc(c["command"].get<std::string>()) << "</code></td><td>" << c["exit_code"].get<int>()
          << "</td><td>" << fixed(c["seconds"].get<double>(), 2) << "</td><td>" << fixed(c["cpu_seconds"].get<double>(), 2)
          << "</td><td>" << fixed(c["max_rss_mb"].get<double>(), 0) << "</td></tr>";
      h << "</table>\n";
    }
    if (r.contains("checks"))
      for (const auto& c : r["checks"]) {
        const std::string type = c["type"].get<std::string>();
        h << "<p><span class=\"badge " << (c["pass"].get<bool>() ? "pass\">ok" : "fail\">fail") << "</span> ";
        if (type == "max_seconds" || type == "max_rss_mb")
          h << (type == "max_seconds" ? "time " : "peak memory ") << number(c["value"]) << " ≤ " << number(c["limit"])
            << (type == "max_seconds" ? " s" : " MiB");
        else
          h << "<code>" << esc(c["output"].get<std::string>()) << "</code> against " << type << " <code>"
            << esc(c["against"].get<std::string>()) << "</code>" << (c.value("updated", false) ? " (baseline written)" : "");
        if (c.contains("failure")) h << "<br><span class=failure>" << esc(c["failure"].get<std::string>()) << "</span>";
        h << "</p>\n";
        if (c.contains("compare")) h << compareNumbers(c["compare"]) << "\n";
        if (c.contains("pictures")) {
          const auto& p = c["pictures"];
          h << "<div class=tri>" << img(dir / p[1].get<std::string>(), type) << img(dir / p[0].get<std::string>(), "current")
            << img(dir / p[2].get<std::string>(), "difference") << "</div>\n";
        }
      }
    if (r.contains("log_tail")) h << "<pre>" << esc(r["log_tail"].get<std::string>()) << "</pre>\n";
  }
  h << "</body></html>\n";

  for (const char* f : {"junit.xml", "report.html", "summary.json"}) io::checkFileOutput(out / f);
  writeText(x.str(), out / "junit.xml");
  writeText(h.str(), out / "report.html");
  nlohmann::json failed = nlohmann::json::array();
  for (const auto& r : results)
    if (!r.value("pass", false)) failed.push_back(r["name"]);
  writeJsonFile({{"name", suite}, {"cases", sum.cases}, {"failures", sum.failures}, {"failed", failed},
                 {"seconds", sum.seconds}, {"vellum_version", vellumVersion()}},
                out / "summary.json");
  return sum;
}

}  // namespace vellum::app
