// Writing outputs (docs/robustness.md, "Outputs"): one module every command writes through. A file
// appears whole or not at all; a device or FIFO is written into, a symlink through to its target;
// an existing file is replaced only under the one overwrite rule below, never an input of the same
// command and never a file porthole wrote for another purpose.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace porthole {

// What porthole wrote a file for, read from its content (JSON keys; files of other tools and
// non-JSON files are kOther). Used to refuse replacing a calibration by a ground truth and so on.
enum class FileKind { kOther, kCalibration, kGroundTruth, kDetections, kDetectionSet, kReport };

// "a porthole calibration", "a render ground truth", … ("a file" for kOther).
std::string FileKindName(FileKind kind);

// The kind of JSON text (kOther when it is not JSON or not porthole's).
FileKind KindOfText(std::string_view text);

// The kind of an existing file: read whole when it is a regular file of at most 64 MiB, else kOther.
FileKind KindOfFile(const std::filesystem::path& path);

// The overwrite rule, one for every command (docs/robustness.md):
//   1. an input of the same command is never written (refused, --force or not);
//   2. a character device or FIFO is written into, never replaced (a block device needs --force);
//   3. a symlink is followed: its final target is judged by these rules and written (atomically,
//      beside the target), the link stays;
//   4. a missing file is created;
//   5. an existing regular file is replaced only with --force (`force`), and even then not when
//      porthole wrote it for another purpose: a calibration, a render ground truth, detections or
//      a report (read from its content) is replaced only by a file of the same kind;
//   6. a directory is never replaced by a file.
struct OutputRules {
  bool force = false;                             // --force: replace an existing regular file
  std::vector<std::filesystem::path> inputs;      // the command's inputs (compared by device and inode)
};

// Checks, before long work, that `path` may be written under `rules` with content of `kind`
// (KindOfText of what will be written); throws InvalidInput(field, ...) naming the path and the
// reason. Writes nothing.
void CheckOutput(const std::filesystem::path& path, const std::string& field, const OutputRules& rules,
                 FileKind kind = FileKind::kOther);

// Writes `content` to `path` under `rules` (CheckOutput with the content's kind first). A regular
// file goes through a temporary `.<name>.tmp.<pid>.<16 hex>` in the target's directory, renamed
// over it; a device or FIFO is opened for writing and written directly. Throws InvalidInput(field,
// ...) when the directory is missing or not writable; on failure an existing file is untouched.
void WriteOutput(const std::filesystem::path& path, std::string_view content, const std::string& field,
                 const OutputRules& rules);

// WriteOutput with `force` (an existing regular file is replaced, if of the same kind) and no
// inputs: for files inside a command's own fresh temporary folder and for callers that check the
// rule themselves (CheckOutput) beforehand.
void WriteFileAtomically(const std::filesystem::path& path, std::string_view content,
                         const std::string& field = "output");

// Where writing `path` lands: symlinks followed to their final target (which may not exist yet).
// Throws InvalidInput(field, ...) on a symlink loop (more than 40 links).
std::filesystem::path ResolveOutputPath(const std::filesystem::path& path, const std::string& field);

// `text` with every byte sequence that is not UTF-8 replaced by U+FFFD (as nlohmann::json's
// error_handler_t::replace does): for names from the file system (which need not be UTF-8) put
// into HTML pages and printed JSON.
std::string ValidUtf8(std::string_view text);

// An exclusive advisory lock (flock) on a directory, held for the object's life; released by the
// kernel when the process dies, even by SIGKILL. Writers of outputs into `dir` hold it while they
// create, fill and rename their temporaries, so whoever holds it knows that any temporary of theirs
// already there is stale. Blocks while another porthole writes into `dir`.
class DirLock {
 public:
  explicit DirLock(const std::filesystem::path& dir);
  ~DirLock();
  DirLock(const DirLock&) = delete;
  DirLock& operator=(const DirLock&) = delete;

 private:
  int fd_ = -1;
};

// Whether `entry_name` is exactly a temporary WriteOutput makes for an output named `name`:
// ".<name>.tmp.<digits>.<16 lowercase hex digits>".
bool IsTemporaryNameOf(const std::string& entry_name, const std::string& name);

// Removes the stale temporaries of the output `name` in `dir`: regular files (not directories, not
// symlinks) whose names are exactly IsTemporaryNameOf. Anything else is left alone. Call only while
// holding DirLock(dir).
void RemoveStaleTemporaries(const std::filesystem::path& dir, const std::string& name);

}  // namespace porthole
