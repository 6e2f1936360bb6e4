// Escaping for gnuplot (report/escape.cc): for any text, a script line using GpText(text) as a title
// passes CheckGnuplotScript, and the literal reads back as the one-line text (no escape lost).
#include <cstddef>
#include <cstdint>
#include <string>

#include "porthole/report/internal.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  const std::string literal = porthole::report::GpText(text);
  porthole::report::CheckGnuplotScript("plot x title " + literal + "\n# " + porthole::report::OneLine(text) + "\nplot x\n",
                                       "fuzz");
  // Undo the single-quote and enhanced-text escapes: the result must be OneLine(text).
  std::string back;
  for (std::size_t i = 1; i + 1 < literal.size(); ++i) {
    if (literal[i] == '\'') ++i;  // '' -> '
    else if (literal[i] == '\\') ++i;
    back += literal[i];
  }
  if (back != porthole::report::OneLine(text) || literal.front() != '\'' || literal.back() != '\'') __builtin_trap();
  return 0;
}
