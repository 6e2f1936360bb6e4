// A bounded reader of Python literals (the syntax of mrcal's .cameramodel files, which mrcal itself
// reads with ast.literal_eval): dicts, lists, tuples, strings ('…', "…", with backslash escapes;
// b'…' bytes read as strings), ints, floats, True, False, None and # comments. Nothing is
// evaluated: any other token (a name, a call, an operator) is an error. Bounded: input ≤ 256 MB,
// nesting ≤ 64 levels.
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <string_view>

namespace porthole::interop {

// The literal as JSON: dict → object (keys must be strings), list and tuple → array, str → string,
// int/float → number, True/False → bool, None → null. Throws InvalidInput(field, "<line>:<col>:
// …") on anything else.
nlohmann::json ParsePythonLiteral(std::string_view text, const std::string& field);

}  // namespace porthole::interop
