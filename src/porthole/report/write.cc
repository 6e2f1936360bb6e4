// Writing the report: a temporary directory beside --out holds everything until gnuplot has made
// every figure; it is then renamed into place (exchanged atomically with an existing report under
// --force, renameat2 RENAME_EXCHANGE, so the old report stays whole until the new one is there).
#include <fcntl.h>
#include <signal.h>
#include <stdio.h>
#include <sys/prctl.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <fstream>
#include <sstream>

#include <fmt/format.h>

#include "porthole/core/atomic_file.h"
#include "porthole/core/error.h"
#include "porthole/core/gnuplot.h"
#include "porthole/report/internal.h"

namespace porthole::report {
namespace fs = std::filesystem;
namespace {

// Removes the directory on destruction unless released.
class TempDir {
 public:
  explicit TempDir(const fs::path& out) {
    std::string tmpl = (out.parent_path() / ("." + out.filename().string() + ".tmp-XXXXXX")).string();
    if (!mkdtemp(tmpl.data())) {
      throw InvalidInput("out", fmt::format("cannot write in {}: {}", out.parent_path().string(), std::strerror(errno)));
    }
    path_ = tmpl;
  }
  ~TempDir() {
    if (!path_.empty()) {
      std::error_code ec;
      fs::remove_all(path_, ec);
    }
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

std::string ReadFile(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  std::ostringstream s;
  s << f.rdbuf();
  return s.str();
}

// What a report folder holds: nothing else is ever in one porthole made.
bool IsReportEntry(const std::string& name) {
  return name == "figures" || name == "report.json" || name == "index.html";
}

// A directory a report may replace: empty, or a porthole report (its report.json says so) holding
// nothing but the report's own entries (a file the user put there, or an input of this command,
// would be lost with it).
bool IsReportDir(const fs::path& dir, std::string* other) {
  for (const auto& e : fs::directory_iterator(dir)) {
    if (!IsReportEntry(e.path().filename().string())) {
      *other = e.path().filename().string();
      return false;
    }
  }
  if (fs::is_empty(dir)) return true;
  return KindOfFile(dir / "report.json") == FileKind::kReport;
}

// Whether `entry` is exactly one of this report's temporary folders: ".<name>.tmp-XXXXXX" (mkdtemp's
// six letters or digits), or that with ".old" (the old report moved aside), a directory (not a
// link) holding only a report's own entries.
bool IsOwnTemporary(const fs::directory_entry& entry, const std::string& name) {
  std::string n = entry.path().filename().string();
  if (n.size() > 4 && n.compare(n.size() - 4, 4, ".old") == 0) n.resize(n.size() - 4);
  const std::string prefix = "." + name + ".tmp-";
  if (n.size() != prefix.size() + 6 || n.compare(0, prefix.size(), prefix) != 0) return false;
  for (std::size_t i = prefix.size(); i < n.size(); ++i) {
    if (!std::isalnum(static_cast<unsigned char>(n[i]))) return false;
  }
  std::error_code ec;
  if (!fs::is_directory(fs::symlink_status(entry.path(), ec))) return false;
  for (auto it = fs::directory_iterator(entry.path(), ec); !ec && it != fs::directory_iterator(); it.increment(ec)) {
    if (!IsReportEntry(it->path().filename().string())) return false;
  }
  return !ec;
}

// Removes the folders a killed run of this report left (IsOwnTemporary); nothing else. Call only
// while holding DirLock(parent).
void RemoveStaleReportTemporaries(const fs::path& parent, const std::string& name) {
  std::error_code ec;
  for (auto it = fs::directory_iterator(parent, ec); !ec && it != fs::directory_iterator(); it.increment(ec)) {
    if (IsOwnTemporary(*it, name)) {
      std::error_code ignore;
      fs::remove_all(it->path(), ignore);
    }
  }
}

// Moves the finished directory to `out`: exchanged atomically with an existing one (which then
// sits at `tmp` and is removed with it), else renamed.
void MoveIntoPlace(const fs::path& tmp, const fs::path& out, bool exists) {
  if (exists) {
    if (renameat2(AT_FDCWD, tmp.c_str(), AT_FDCWD, out.c_str(), RENAME_EXCHANGE) == 0) return;
    // A file system without RENAME_EXCHANGE: move the old one aside first.
    const fs::path aside = tmp.string() + ".old";
    fs::rename(out, aside);
    fs::rename(tmp, out);
    fs::remove_all(aside);
    return;
  }
  if (rename(tmp.c_str(), out.c_str()) != 0) {
    throw InvalidInput("out", fmt::format("cannot create {}: {}", out.string(), std::strerror(errno)));
  }
}

}  // namespace

ReportSummary WriteReport(const ReportInputs& inputs, const ReportOptions& options) {
  Steps steps(options);
  const auto t0 = std::chrono::steady_clock::now();
  if (options.out_dir.empty()) throw InvalidInput("out", "give the report's directory");
  fs::path out = fs::absolute(options.out_dir).lexically_normal();
  if (out.filename().empty()) out = out.parent_path();  // a trailing slash
  if (!fs::is_directory(out.parent_path())) {
    throw InvalidInput("out", fmt::format("{} is not a directory", out.parent_path().string()));
  }
  const bool exists = fs::exists(fs::symlink_status(out));
  if (exists) {
    if (!fs::is_directory(fs::symlink_status(out))) {
      throw InvalidInput("out", fmt::format("{} exists and is not a directory", out.string()));
    }
    if (!options.force && !fs::is_empty(out)) {
      throw InvalidInput("out", fmt::format("{} exists: `force` replaces it", out.string()));
    }
    std::string other;
    if (!IsReportDir(out, &other)) {
      throw InvalidInput("out", other.empty()
                                      ? fmt::format("{} is not empty and holds no porthole report: not replaced", out.string())
                                      : fmt::format("{} is not empty and holds {}, which is not part of a porthole report: not replaced",
                                                    out.string(), other));
    }
  }
  // Held until the report is in place: whoever holds it knows that any .<name>.tmp-* beside --out
  // is the leftover of a killed run, and removes it (docs/robustness.md).
  const DirLock lock(out.parent_path());
  RemoveStaleReportTemporaries(out.parent_path(), out.filename().string());
  TempDir tmp(out);
  const fs::path figdir = tmp.path() / "figures";
  fs::create_directory(figdir);

  const Results results = Gather(inputs, steps);
  const std::vector<Figure> figures = MakeFigures(results);
  std::map<std::string, std::string> svgs;
  steps.Run("figures (gnuplot)", [&] {
    std::string all = "# Remakes every figure of the report: gnuplot all.gp (in this directory).\n";
    for (const auto& f : figures) {
      WriteFileAtomically(figdir / (f.id + ".dat"), f.data, "out");
      WriteFileAtomically(figdir / (f.id + ".gp"), FigureScript(f), "out");
      all += fmt::format("load \"{}.gp\"\n", f.id);
    }
    WriteFileAtomically(figdir / "all.gp", all, "out");
    RunGnuplot(options.gnuplot, figdir, "all.gp");
    for (const auto& f : figures) {
      for (const char* ext : {".png", ".svg"}) {
        const fs::path p = figdir / (f.id + ext);
        std::error_code ec;
        if (fs::file_size(p, ec) == 0 || ec) {
          throw InvalidInput("gnuplot", fmt::format("made no {}{}", f.id, ext));
        }
      }
      svgs[f.id] = InlineSvg(ReadFile(figdir / (f.id + ".svg")), f.id);
    }
  });
  steps.Run("page and JSON", [&] {
    WriteFileAtomically(tmp.path() / "report.json", ReportJson(results, figures).dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n", "out");
    WriteFileAtomically(tmp.path() / "index.html", ValidUtf8(ReportHtml(results, figures, svgs)), "out");
  });
  chmod(tmp.path().c_str(), 0755);  // mkdtemp made it private
  MoveIntoPlace(tmp.path(), out, exists);

  ReportSummary summary;
  summary.index_html = out / "index.html";
  for (const auto& f : figures) summary.figures.push_back(f.id);
  summary.step_seconds = steps.seconds();
  summary.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return summary;
}

}  // namespace porthole::report
