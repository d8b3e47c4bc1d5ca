// palpate/params.h — typed parameter tables: one place that names each scene key, its type, unit,
// valid range and default (the struct member's initialiser). The scene parser, its error messages
// and docs/scene-format.md's reference are all driven by these tables.
#pragma once

#include <palpate/core.h>

#include <limits>
#include <filesystem>
#include <span>
#include <string>
#include <variant>

namespace palpate {

inline constexpr double kInf = std::numeric_limits<double>::infinity();

template <class Def>
struct Param {
  using Field = std::variant<double Def::*, int Def::*, bool Def::*, Vec3 Def::*, std::string Def::*,
                             std::filesystem::path Def::*>;
  const char* key;
  Field field;
  double min = -kInf;  // inclusive bounds for numbers (each component of a Vec3)
  double max = kInf;
  const char* unit = "";      // SI unit, "" when dimensionless
  const char* doc = "";       // one line: what it means
  const char* choices = "";   // for strings: allowed values separated by '|', "" = any
  const char* absent = "";    // what leaving the key out means, when not the default value
};

}  // namespace palpate
