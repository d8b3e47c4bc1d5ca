// palpate/scene.h — the YAML scene loader (the io layer): a scene file to a SceneDef
// (palpate/scene_def.h), and the Markdown reference of every key.
#pragma once

#include <palpate/core.h>
#include <palpate/scene_def.h>

#include <filesystem>
#include <string>

namespace palpate {

// Read and validate a YAML scene. Relative paths in it are resolved against its directory.
// Unknown keys, missing required keys, wrong types and out-of-range values are errors naming
// the file, line, key and the valid range.
Result<SceneDef> load_scene(const std::filesystem::path& file);
// The same from text; `name` stands for the file in messages, `base_dir` resolves paths.
Result<SceneDef> parse_scene(const std::string& yaml, const std::string& name,
                             const std::filesystem::path& base_dir = {});

// Markdown reference of every scene key: type, unit, range and default (from the tables).
std::string scene_reference_markdown();
// The JSON Schema (draft 2020-12) of a scene file, from the same tables: every key's type, unit,
// range, choices and default, the required keys and the rules across keys the schema can state
// (docs/scene-format.md, "Schema"). Shipped as data/schema/scene.schema.json; `palpate schema`.
std::string scene_json_schema();

}  // namespace palpate
