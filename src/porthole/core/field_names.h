// Library errors name the option field they concern (InvalidInput::field(): `f_number`,
// `wd_mm`, `lens`); each front end says it in its own words — the CLI its flags, Python its
// keywords. One table per front end, applied where the error leaves the library.
#pragma once

#include <initializer_list>
#include <string>
#include <string_view>

#include "porthole/core/error.h"

namespace porthole {

struct FieldName {
  std::string_view field;  // the library's field (a prefix: "lens" also renames "lens.f_number_min")
  std::string_view name;   // what the front end calls it ("--lens")
};

// Runs f(); an InvalidInput whose field is listed (or begins with a listed field followed by '.')
// is rethrown with that part renamed and the rule unchanged. Anything else passes through.
template <typename F>
auto WithFieldNames(std::initializer_list<FieldName> names, F&& f) -> decltype(f()) {
  try {
    return f();
  } catch (const InvalidInput& e) {
    const std::string& field = e.field();
    for (const FieldName& n : names) {
      if (field.rfind(n.field, 0) != 0) continue;
      const std::string rest = field.substr(n.field.size());
      if (!rest.empty() && rest[0] != '.') continue;
      const std::string rule = std::string(e.what()).substr(field.size() + 2);  // "field: rule"
      throw InvalidInput(std::string(n.name) + rest, rule);
    }
    throw;
  }
}

}  // namespace porthole
