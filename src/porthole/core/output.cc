#include "porthole/core/output.h"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>

#include <fmt/format.h>

#include "porthole/core/error.h"

namespace porthole {
namespace fs = std::filesystem;

namespace {

constexpr std::uintmax_t kMaxKindFileBytes = 64u << 20;

// Top-level keys of a JSON object and the kind of each value ('o' object, 'a' array, 's' other),
// by nlohmann's SAX interface: constant memory whatever the file holds.
struct TopKeys : nlohmann::json_sax<nlohmann::json> {
  std::map<std::string, char> keys;
  bool top_is_object = false;
  int depth = 0;
  std::string pending;

  void Value(char type) {
    if (depth == 1 && !pending.empty()) keys[pending] = type;
    pending.clear();
  }
  bool null() override { return Value('s'), true; }
  bool boolean(bool) override { return Value('s'), true; }
  bool number_integer(number_integer_t) override { return Value('s'), true; }
  bool number_unsigned(number_unsigned_t) override { return Value('s'), true; }
  bool number_float(number_float_t, const string_t&) override { return Value('s'), true; }
  bool string(string_t&) override { return Value('s'), true; }
  bool binary(binary_t&) override { return Value('s'), true; }
  bool start_object(std::size_t) override {
    if (depth == 0) top_is_object = true;
    Value('o');
    return ++depth <= 64;
  }
  bool key(string_t& k) override {
    if (depth == 1) pending = k;
    return true;
  }
  bool end_object() override { return --depth, true; }
  bool start_array(std::size_t) override {
    Value('a');
    return ++depth <= 64;
  }
  bool end_array() override { return --depth, true; }
  bool parse_error(std::size_t, const std::string&, const nlohmann::detail::exception&) override { return false; }
};

// 16 lowercase hex digits from the system's random source.
std::string RandomHex16() {
  std::random_device rd;
  const std::uint64_t v = (static_cast<std::uint64_t>(rd()) << 32) ^ rd();
  return fmt::format("{:016x}", v);
}

std::string Quote(const fs::path& p) { return p.string(); }

// lstat/stat without exceptions: nullopt-like via the return flag.
bool Stat(const fs::path& p, struct stat* st) { return ::stat(p.c_str(), st) == 0; }

// Writes all of `content` to an open descriptor.
bool WriteAll(int fd, std::string_view content) {
  std::size_t done = 0;
  while (done < content.size()) {
    const ssize_t n = ::write(fd, content.data() + done, content.size() - done);
    if (n < 0) {
      if (errno == EINTR) continue;
      return false;
    }
    done += static_cast<std::size_t>(n);
  }
  return true;
}

}  // namespace

std::string FileKindName(FileKind kind) {
  switch (kind) {
    case FileKind::kCalibration: return "a porthole calibration";
    case FileKind::kGroundTruth: return "a render ground truth";
    case FileKind::kDetections: return "porthole detections";
    case FileKind::kDetectionSet: return "a porthole detection set";
    case FileKind::kReport: return "a porthole report";
    case FileKind::kOther: break;
  }
  return "a file";
}

FileKind KindOfText(std::string_view text) {
  std::size_t i = 0;
  while (i < text.size() && (text[i] == ' ' || text[i] == '\n' || text[i] == '\r' || text[i] == '\t')) ++i;
  if (i == text.size() || text[i] != '{') return FileKind::kOther;  // not a JSON object
  TopKeys sax;
  nlohmann::json::sax_parse(text, &sax, nlohmann::json::input_format_t::json, /*strict=*/false);
  if (!sax.top_is_object) return FileKind::kOther;
  const auto has = [&](const char* k, char type = 0) {
    const auto it = sax.keys.find(k);
    return it != sax.keys.end() && (type == 0 || it->second == type);
  };
  if (has("porthole_report")) return FileKind::kReport;
  if (has("points", 'a') && has("pose", 'o') && has("camera", 'o')) return FileKind::kGroundTruth;
  if (has("ids", 'a') && has("points_px", 'a')) return FileKind::kDetections;
  if (has("camera", 'o') || has("rig", 'o')) return FileKind::kCalibration;  // a camera's or a rig's
  if (has("images", 'a') && has("target", 's')) return FileKind::kDetectionSet;
  return FileKind::kOther;
}

FileKind KindOfFile(const fs::path& path) {
  struct stat st {};
  if (!Stat(path, &st) || !S_ISREG(st.st_mode) || static_cast<std::uintmax_t>(st.st_size) > kMaxKindFileBytes) {
    return FileKind::kOther;
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) return FileKind::kOther;
  std::ostringstream s;
  s << in.rdbuf();
  return KindOfText(s.str());
}

fs::path ResolveOutputPath(const fs::path& path, const std::string& field) {
  fs::path p = path;
  for (int hops = 0;; ++hops) {
    std::error_code ec;
    const fs::file_status st = fs::symlink_status(p, ec);
    if (ec || !fs::is_symlink(st)) return p;
    if (hops >= 40) throw InvalidInput(field, Quote(path) + ": too many levels of symbolic links");
    const fs::path target = fs::read_symlink(p, ec);
    if (ec) throw InvalidInput(field, Quote(path) + ": cannot read the link: " + ec.message());
    p = target.is_absolute() ? target : (p.parent_path() / target);
  }
}

void CheckOutput(const fs::path& path, const std::string& field, const OutputRules& rules, FileKind kind) {
  if (path.empty()) throw InvalidInput(field, "give a file name");
  const fs::path target = ResolveOutputPath(path, field);
  const std::string shown = target == path ? Quote(path) : Quote(path) + " (a link to " + Quote(target) + ")";
  const fs::path dir = target.has_parent_path() ? target.parent_path() : fs::path(".");
  struct stat st {};
  if (!Stat(target, &st)) {
    if (errno != ENOENT && errno != ENOTDIR) throw InvalidInput(field, shown + ": " + std::strerror(errno));
    struct stat ds {};
    if (!Stat(dir, &ds) || !S_ISDIR(ds.st_mode)) throw InvalidInput(field, "directory does not exist: " + Quote(dir));
    if (access(dir.c_str(), W_OK | X_OK) != 0) throw InvalidInput(field, Quote(dir) + " is not writable");
    return;  // rule 4: a new file
  }
  for (const fs::path& in : rules.inputs) {  // rule 1
    struct stat is {};
    if (Stat(in, &is) && is.st_dev == st.st_dev && is.st_ino == st.st_ino) {
      throw InvalidInput(field, shown + " is an input of this command: not replaced (choose another name)");
    }
  }
  if (S_ISDIR(st.st_mode)) throw InvalidInput(field, shown + " is a directory");  // rule 6
  if (S_ISCHR(st.st_mode) || S_ISFIFO(st.st_mode)) {  // rule 2: written into
    if (access(target.c_str(), W_OK) != 0) throw InvalidInput(field, shown + " is not writable");
    return;
  }
  if (S_ISBLK(st.st_mode)) {
    if (!rules.force) throw InvalidInput(field, shown + " is a block device: `force` writes into it");
    return;
  }
  if (!S_ISREG(st.st_mode)) throw InvalidInput(field, shown + " is not a regular file, a device or a FIFO");
  const FileKind existing = KindOfFile(target);  // rule 5
  if (!rules.force) {
    throw InvalidInput(field, shown + " exists" + (existing == FileKind::kOther ? "" : " (" + FileKindName(existing) + ")") +
                                  ": `force` replaces it");
  }
  if (existing != FileKind::kOther && existing != kind) {
    throw InvalidInput(field, shown + " is " + FileKindName(existing) + ", not " + FileKindName(kind) +
                                  ": not replaced, even with `force` (remove it yourself or choose another name)");
  }
  if (access(dir.c_str(), W_OK | X_OK) != 0) throw InvalidInput(field, Quote(dir) + " is not writable");
}

DirLock::DirLock(const fs::path& dir) {
  fd_ = open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd_ < 0) return;  // the caller's own checks report a missing directory
  while (flock(fd_, LOCK_EX) != 0 && errno == EINTR) {
  }
}

DirLock::~DirLock() {
  if (fd_ >= 0) close(fd_);  // releases the lock
}

bool IsTemporaryNameOf(const std::string& entry_name, const std::string& name) {
  const std::string prefix = "." + name + ".tmp.";
  if (entry_name.size() <= prefix.size() || entry_name.compare(0, prefix.size(), prefix) != 0) return false;
  const std::string_view rest = std::string_view(entry_name).substr(prefix.size());  // <digits>.<16 hex>
  const std::size_t dot = rest.find('.');
  if (dot == 0 || dot == std::string_view::npos || dot > 10) return false;
  for (std::size_t i = 0; i < dot; ++i) {
    if (rest[i] < '0' || rest[i] > '9') return false;
  }
  const std::string_view hex = rest.substr(dot + 1);
  if (hex.size() != 16) return false;
  for (const char c : hex) {
    if (!((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'))) return false;
  }
  return true;
}

void RemoveStaleTemporaries(const fs::path& dir, const std::string& name) {
  std::error_code ec;
  for (auto it = fs::directory_iterator(dir, ec); !ec && it != fs::directory_iterator(); it.increment(ec)) {
    if (!IsTemporaryNameOf(it->path().filename().string(), name)) continue;
    std::error_code ignore;
    if (fs::is_regular_file(fs::symlink_status(it->path(), ignore))) fs::remove(it->path(), ignore);  // never remove_all
  }
}

void WriteOutput(const fs::path& path, std::string_view content, const std::string& field, const OutputRules& rules) {
  CheckOutput(path, field, rules, KindOfText(content));
  const fs::path target = ResolveOutputPath(path, field);
  struct stat st {};
  if (Stat(target, &st) && !S_ISREG(st.st_mode)) {  // a device or FIFO (CheckOutput allowed it): written into
    const int fd = open(target.c_str(), O_WRONLY | O_CLOEXEC | O_NOCTTY);
    if (fd < 0) throw InvalidInput(field, "cannot open " + Quote(target) + ": " + std::strerror(errno));
    const bool ok = WriteAll(fd, content);
    const int err = errno;
    close(fd);
    if (!ok) throw InvalidInput(field, "write failed for " + Quote(target) + ": " + std::strerror(err));
    return;
  }
  const fs::path dir = target.has_parent_path() ? target.parent_path() : fs::path(".");
  const std::string name = target.filename().string();
  const DirLock lock(dir);
  RemoveStaleTemporaries(dir, name);
  const fs::path tmp = dir / fmt::format(".{}.tmp.{}.{}", name, getpid(), RandomHex16());
  const int fd = open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
  if (fd < 0) throw InvalidInput(field, "cannot write in " + Quote(dir) + ": " + std::strerror(errno));
  const bool ok = WriteAll(fd, content);
  const int err = errno;
  if (close(fd) != 0 || !ok) {
    std::error_code ignore;
    fs::remove(tmp, ignore);
    throw InvalidInput(field, "write failed for " + Quote(target) + ": " + std::strerror(ok ? errno : err));
  }
  std::error_code ec;
  fs::rename(tmp, target, ec);
  if (ec) {
    std::error_code ignore;
    fs::remove(tmp, ignore);
    throw InvalidInput(field, "cannot replace " + Quote(target) + ": " + ec.message());
  }
}

std::string ValidUtf8(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  std::size_t i = 0;
  const auto cont = [&](std::size_t k) { return k < text.size() && (static_cast<unsigned char>(text[k]) & 0xC0) == 0x80; };
  while (i < text.size()) {
    const auto c = static_cast<unsigned char>(text[i]);
    std::size_t n = 0;  // continuation bytes of a valid sequence starting here
    if (c < 0x80) {
      n = 0;
    } else if (c >= 0xC2 && c <= 0xDF) {
      n = cont(i + 1) ? 1 : SIZE_MAX;
    } else if (c >= 0xE0 && c <= 0xEF) {
      const auto c1 = i + 1 < text.size() ? static_cast<unsigned char>(text[i + 1]) : 0;
      const bool ok1 = (c == 0xE0) ? (c1 >= 0xA0 && c1 <= 0xBF) : (c == 0xED) ? (c1 >= 0x80 && c1 <= 0x9F) : cont(i + 1);
      n = ok1 && cont(i + 2) ? 2 : SIZE_MAX;
    } else if (c >= 0xF0 && c <= 0xF4) {
      const auto c1 = i + 1 < text.size() ? static_cast<unsigned char>(text[i + 1]) : 0;
      const bool ok1 = (c == 0xF0) ? (c1 >= 0x90 && c1 <= 0xBF) : (c == 0xF4) ? (c1 >= 0x80 && c1 <= 0x8F) : cont(i + 1);
      n = ok1 && cont(i + 2) && cont(i + 3) ? 3 : SIZE_MAX;
    } else {
      n = SIZE_MAX;
    }
    if (n == SIZE_MAX) {
      out += "\xEF\xBF\xBD";
      ++i;
    } else {
      out.append(text.substr(i, n + 1));
      i += n + 1;
    }
  }
  return out;
}

void WriteFileAtomically(const fs::path& path, std::string_view content, const std::string& field) {
  WriteOutput(path, content, field, OutputRules{.force = true, .inputs = {}});
}

}  // namespace porthole
