// A small, bounded XML reader for calibration files from other tools (Metashape): the document as a
// flat list of elements (name, attributes, text, children), built from Expat's streaming events,
// so nothing recurses on the input's nesting. Untrusted input (docs/robustness.md): a DOCTYPE (and
// with it every entity definition) is refused, nesting is at most kMaxXmlDepth, the element count
// at most kMaxXmlElements and the text at most the file-size cap; any breach or syntax error is an
// InvalidInput(field, "line N: …").
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace porthole::interop {

inline constexpr int kMaxXmlDepth = 32;
inline constexpr int kMaxXmlElements = 100000;

struct XmlElement {
  std::string name;
  std::vector<std::pair<std::string, std::string>> attributes;
  std::string text;           // the character data directly inside, concatenated
  std::vector<int> children;  // indices into XmlDocument::elements, in document order
  int line = 0;               // where it starts, for messages
};

struct XmlDocument {
  std::vector<XmlElement> elements;  // [0] is the root

  const XmlElement& root() const { return elements.front(); }
  // The first child of `parent` called `name`; nullptr when there is none.
  const XmlElement* Child(const XmlElement& parent, std::string_view name) const;
  // The first element called `name` anywhere (document order); nullptr when there is none.
  const XmlElement* Find(std::string_view name) const;
  static std::optional<std::string> Attribute(const XmlElement& e, std::string_view name);
};

// Parses `text` (UTF-8 or as its declaration says). Throws InvalidInput(field, …).
XmlDocument ParseXml(std::string_view text, const std::string& field);

}  // namespace porthole::interop
