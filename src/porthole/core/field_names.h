// Library errors name the option field they concern (InvalidInput::field(): `f_number`,
// `wd_mm`, `lens`); each front end says it in its own words — the CLI its flags, Python its
// keywords. One table per front end, applied where the error leaves the library.
#pragma once

#include <initializer_list>
#include <optional>
#include <string>
#include <string_view>

#include "porthole/core/error.h"

namespace porthole {

struct FieldName {
  std::string_view field;  // the library's field (a prefix: "lens" also renames "lens.f_number_min")
  std::string_view name;   // what the front end calls it ("--lens")
};

// The rule of an error may name another field the user can set, written between backquotes
// ("… set `extrapolate` to use it anyway"); a front end's table renames those too ("--extrapolate").
// A quoted field the table does not list stays quoted for an outer table (keep_unknown), or loses its
// quotes when this is the last table (the front end's own error handler).
inline std::string RenameQuotedFields(std::initializer_list<FieldName> names, std::string_view rule,
                                      bool keep_unknown = false);

// `e` in a front end's words: its field renamed when the table lists it (or it begins with a listed
// field followed by '.'), and the fields its rule names (`quoted`) renamed as well.
inline InvalidInput RenameFields(std::initializer_list<FieldName> names, const InvalidInput& e,
                                 bool keep_unknown = true) {
  std::string field = e.field();
  const std::string rule = std::string(e.what()).substr(field.size() + 2);  // "field: rule"
  for (const FieldName& n : names) {
    if (field.rfind(n.field, 0) != 0) continue;
    const std::string rest = field.substr(n.field.size());
    if (!rest.empty() && rest[0] != '.') continue;
    field = std::string(n.name) + rest;
    break;
  }
  return InvalidInput(field, RenameQuotedFields(names, rule, keep_unknown));
}

// The same renaming by a rule instead of a table: `lookup(field)` gives the front end's word for a
// field (or the head of a dotted field, "air_calibration" of "air_calibration.camera.K1"), or
// nothing. The CLI's last table is of this kind: a field is its flag when the command has one of
// that name (`pixel_pitch_mm` → --pixel-pitch-mm), so the library names its fields and never a flag.
template <typename Lookup>
std::string RenameQuotedFieldsBy(const Lookup& lookup, std::string_view rule, std::string_view unknown_suffix = "",
                                 bool keep_unknown = false) {
  std::string out;
  std::size_t i = 0;
  while (i < rule.size()) {
    const std::size_t open = rule.find('`', i);
    const std::size_t close = open == std::string_view::npos ? open : rule.find('`', open + 1);
    if (close == std::string_view::npos) break;
    out.append(rule.substr(i, open - i));
    const std::string_view quoted = rule.substr(open + 1, close - open - 1);
    if (const auto word = lookup(quoted)) {
      out.append(*word);
    } else if (keep_unknown) {
      out.append(rule.substr(open, close - open + 1));
    } else {
      out.append(quoted);
      out.append(unknown_suffix);
    }
    i = close + 1;
  }
  out.append(rule.substr(i));
  return out;
}

inline std::string RenameQuotedFields(std::initializer_list<FieldName> names, std::string_view rule,
                                      bool keep_unknown) {
  const auto lookup = [&](std::string_view quoted) -> std::optional<std::string> {
    for (const FieldName& n : names) {
      if (n.field == quoted) return std::string(n.name);
    }
    return std::nullopt;
  };
  return RenameQuotedFieldsBy(lookup, rule, "", keep_unknown);
}

template <typename Lookup>
InvalidInput RenameFieldsBy(const Lookup& lookup, const InvalidInput& e) {
  std::string field = e.field();
  const std::string rule = std::string(e.what()).substr(field.size() + 2);  // "field: rule"
  const std::size_t head_end = field.find_first_of(".:[ ");
  if (const auto word = lookup(std::string_view(field).substr(0, head_end))) {
    field = *word + (head_end == std::string::npos ? std::string() : field.substr(head_end));
  }
  return InvalidInput(field, RenameQuotedFieldsBy(lookup, rule));
}

// Runs f(); an InvalidInput is rethrown in the table's words (RenameFields; fields the table does
// not list stay as they are, for the front end's last table). Anything else passes through.
template <typename F>
auto WithFieldNames(std::initializer_list<FieldName> names, F&& f) -> decltype(f()) {
  try {
    return f();
  } catch (const InvalidInput& e) {
    InvalidInput renamed = RenameFields(names, e);
    if (std::string_view(renamed.what()) == e.what()) throw;
    throw renamed;
  }
}

}  // namespace porthole
