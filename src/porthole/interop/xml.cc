#include "porthole/interop/xml.h"

#include <expat.h>
#include <fmt/format.h>

#include <climits>
#include <memory>

#include "porthole/core/error.h"

namespace porthole::interop {
namespace {

struct Builder {
  XML_Parser parser = nullptr;
  XmlDocument doc;
  std::vector<int> open;  // the path from the root to the current element
  std::string error;      // set by a handler that stopped the parser

  void Stop(std::string why) {
    if (error.empty()) error = std::move(why);
    XML_StopParser(parser, XML_FALSE);
  }
};

void OnStart(void* data, const XML_Char* name, const XML_Char** attrs) {
  auto* b = static_cast<Builder*>(data);
  if (!b->error.empty()) return;
  if (static_cast<int>(b->open.size()) >= kMaxXmlDepth) {
    return b->Stop(fmt::format("nested deeper than {} elements", kMaxXmlDepth));
  }
  if (static_cast<int>(b->doc.elements.size()) >= kMaxXmlElements) {
    return b->Stop(fmt::format("more than {} elements", kMaxXmlElements));
  }
  if (b->open.empty() && !b->doc.elements.empty()) return b->Stop("more than one root element");
  XmlElement e;
  e.name = name;
  e.line = static_cast<int>(XML_GetCurrentLineNumber(b->parser));
  for (int i = 0; attrs[i] != nullptr; i += 2) e.attributes.emplace_back(attrs[i], attrs[i + 1]);
  const int index = static_cast<int>(b->doc.elements.size());
  if (!b->open.empty()) b->doc.elements[b->open.back()].children.push_back(index);
  b->doc.elements.push_back(std::move(e));
  b->open.push_back(index);
}

void OnEnd(void* data, const XML_Char*) {
  auto* b = static_cast<Builder*>(data);
  if (!b->open.empty()) b->open.pop_back();
}

void OnText(void* data, const XML_Char* s, int len) {
  auto* b = static_cast<Builder*>(data);
  if (!b->open.empty() && b->error.empty()) b->doc.elements[b->open.back()].text.append(s, len);
}

void OnDoctype(void* data, const XML_Char*, const XML_Char*, const XML_Char*, int) {
  static_cast<Builder*>(data)->Stop("a DOCTYPE is not accepted (calibration files have none)");
}

void OnEntity(void* data, const XML_Char*, int, const XML_Char*, int, const XML_Char*,
              const XML_Char*, const XML_Char*, const XML_Char*) {
  static_cast<Builder*>(data)->Stop("entity definitions are not accepted");
}

}  // namespace

const XmlElement* XmlDocument::Child(const XmlElement& parent, std::string_view name) const {
  for (int i : parent.children) {
    if (elements[i].name == name) return &elements[i];
  }
  return nullptr;
}

const XmlElement* XmlDocument::Find(std::string_view name) const {
  for (const auto& e : elements) {
    if (e.name == name) return &e;
  }
  return nullptr;
}

std::optional<std::string> XmlDocument::Attribute(const XmlElement& e, std::string_view name) {
  for (const auto& [k, v] : e.attributes) {
    if (k == name) return v;
  }
  return std::nullopt;
}

XmlDocument ParseXml(std::string_view text, const std::string& field) {
  if (text.size() > static_cast<std::size_t>(INT_MAX)) throw InvalidInput(field, "XML file too large");
  std::unique_ptr<XML_ParserStruct, decltype(&XML_ParserFree)> parser(XML_ParserCreate(nullptr),
                                                                       &XML_ParserFree);
  if (!parser) throw std::bad_alloc();
  Builder b;
  b.parser = parser.get();
  XML_SetUserData(b.parser, &b);
  XML_SetElementHandler(b.parser, OnStart, OnEnd);
  XML_SetCharacterDataHandler(b.parser, OnText);
  XML_SetStartDoctypeDeclHandler(b.parser, OnDoctype);
  XML_SetEntityDeclHandler(b.parser, OnEntity);
  const XML_Status status =
      XML_Parse(b.parser, text.data(), static_cast<int>(text.size()), XML_TRUE);
  const int line = static_cast<int>(XML_GetCurrentLineNumber(b.parser));
  if (!b.error.empty()) throw InvalidInput(field, fmt::format("line {}: {}", line, b.error));
  if (status != XML_STATUS_OK) {
    throw InvalidInput(field, fmt::format("line {}: not XML ({})", line,
                                          XML_ErrorString(XML_GetErrorCode(b.parser))));
  }
  if (b.doc.elements.empty()) throw InvalidInput(field, "not XML: no element");
  return std::move(b.doc);
}

}  // namespace porthole::interop
