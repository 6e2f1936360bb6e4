// Running a peer benchmark in another process (a Python script with NumPy, OpenCV or mrcal): its
// standard output, or "" when it could not run or exited non-zero. The caller parses what it prints.
#pragma once

#include <cstdio>
#include <string>

namespace porthole::bench {

inline std::string RunPeer(const std::string& command) {
  std::string out;
  if (FILE* p = popen(command.c_str(), "r")) {
    char buf[4096];
    while (fgets(buf, sizeof buf, p) != nullptr) out += buf;
    if (pclose(p) != 0) out.clear();
  }
  return out;
}

}  // namespace porthole::bench
