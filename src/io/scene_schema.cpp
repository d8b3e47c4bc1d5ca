// scene_schema.cpp — the JSON Schema (draft 2020-12) of a scene file, generated from the same
// parameter tables and section lists the parser reads (scene_params.h): each key's type, unit,
// range, choices and default, the required keys, and the rules the tables state across keys
// (exactly one of patch and mesh; tissues or an anatomy; the material by the tissue's model).
// What only the loader can check (files that exist, a vein inside its region, a patch that fits
// in memory) it checks, with the same key in its message.
#include "io/scene_params.h"

#include <palpate/charged_def.h>
#include <palpate/scene.h>
#include <palpate/spring_def.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstring>
#include <span>
#include <string>
#include <type_traits>

namespace palpate {

namespace {

using json = nlohmann::ordered_json;

json number_schema(double min, double max, const char* type) {
  json s = {{"type", type}};
  if (std::isfinite(min)) s["minimum"] = min;
  if (std::isfinite(max)) s["maximum"] = max;
  return s;
}

// The default a default-constructed Def holds, as JSON.
template <class Def>
json default_value(const Def& def, const typename Param<Def>::Field& field) {
  return std::visit(
      [&](auto member) -> json {
        const auto& v = def.*member;
        using T = std::remove_cvref_t<decltype(v)>;
        if constexpr (std::is_same_v<T, Vec3>) return json::array({v.x(), v.y(), v.z()});
        else if constexpr (std::is_same_v<T, std::filesystem::path>) return v.string();
        else return v;
      },
      field);
}

// One table's keys as the properties of an object schema.
template <class Def>
json table_properties(std::span<const char* const> required) {
  // static: with a local, GCC 12 at -O3 gives a false -Wmaybe-uninitialized through std::visit.
  static const Def def{};
  json props = json::object();
  for (const Param<Def>& p : param_table(static_cast<const Def*>(nullptr))) {
    json s;
    switch (static_cast<FieldKind>(p.field.index())) {
      case FieldKind::number: s = number_schema(p.min, p.max, "number"); break;
      case FieldKind::integer: s = number_schema(p.min, p.max, "integer"); break;
      case FieldKind::boolean: s = {{"type", "boolean"}}; break;
      case FieldKind::vec3:
        s = {{"type", "array"}, {"items", number_schema(p.min, p.max, "number")}, {"minItems", 3}, {"maxItems", 3}};
        break;
      case FieldKind::string:
        s = {{"type", "string"}};
        if (*p.choices) {
          json choices = json::array();
          std::string c;
          for (const char* q = p.choices;; ++q) {
            if (*q == '|' || *q == '\0') {
              choices.push_back(c);
              c.clear();
              if (*q == '\0') break;
            } else {
              c += *q;
            }
          }
          s["enum"] = choices;
        }
        break;
      case FieldKind::path: s = {{"type", "string"}}; break;
    }
    std::string description = p.doc;
    if (*p.unit) description += std::string(" [") + p.unit + "]";
    if (*p.absent) description += std::string(". Left out: ") + p.absent;
    s["description"] = description;
    if (*p.unit) s["x-unit"] = p.unit;
    const bool is_required = std::any_of(required.begin(), required.end(),
                                         [&](const char* k) { return std::strcmp(k, p.key) == 0; });
    if (!is_required && !*p.absent) s["default"] = default_value(def, p.field);
    props[p.key] = std::move(s);
  }
  return props;
}

template <class Def>
json object_schema(const char* description, std::span<const char* const> required = {}) {
  json s = {{"type", "object"}, {"description", description}};
  s["properties"] = table_properties<Def>(required);
  if (!required.empty()) s["required"] = json(std::vector<std::string>(required.begin(), required.end()));
  s["additionalProperties"] = false;
  return s;
}

json ref(const char* name) { return {{"$ref", std::string("#/$defs/") + name}}; }

// A structural key's description, from the section list the parser and the reference share.
const char* section_doc(std::span<const SectionKey> keys, const char* key) {
  for (const SectionKey& k : keys)
    if (std::strcmp(k.key, key) == 0) return k.doc;
  return "";
}

}  // namespace

std::string scene_json_schema() {
  json defs = json::object();
  defs["tool"] = object_schema<ToolDef>("The tool held through the device; its tip is the haptic interaction point.");
  json waypoint = object_schema<Waypoint>("A timed position of the tool, optionally its direction.", kWaypointRequired);
  json device = object_schema<DeviceDef>("Where the tool's pose comes from (docs/haptics.md).");
  device["properties"]["waypoints"] = {{"type", "array"},
                                       {"description", section_doc(kDeviceSections, "waypoints")},
                                       {"items", ref("waypoint")}};
  defs["device"] = device;
  defs["waypoint"] = waypoint;
  defs["camera"] = object_schema<CameraDef>("Optional viewpoint for drawing.");
  defs["charged_material"] = object_schema<ChargedMaterialDef>("Material of a charged-particle patch.");
  defs["spring_material"] = object_schema<SpringMaterialDef>("Material of a mass-spring-damper organ.");
  json anatomy = object_schema<NeckDef>("A generated neck (docs/cvc.md): skin, fat, ijv (vein) and cca (artery).");
  json layers = {{"type", "object"},
                 {"description", section_doc(kAnatomySections, "layers")},
                 {"properties", json::object()},
                 {"additionalProperties", false}};
  for (const char* layer : kNeckLayers) layers["properties"][layer] = ref("charged_material");
  anatomy["properties"]["layers"] = layers;
  defs["anatomy"] = anatomy;
  json probe = object_schema<ProbeDef>("The ultrasound probe held in the other hand (docs/ultrasound.md).");
  probe["properties"]["device"] = ref("device");
  defs["probe"] = probe;
  json grasper = object_schema<GrasperDef>("A grasper held in the other hand: a second tool on the tissues.");
  grasper["properties"]["device"] = ref("device");
  defs["grasper"] = grasper;
  defs["patch"] = object_schema<PatchDef>("A generated rectangular patch of particles or vertices.");
  defs["mesh"] = object_schema<MeshRef>("A mesh file and how to place it.", kMeshRequired);
  json tissue = object_schema<TissueDef>("A tissue: exactly one of patch and mesh; names are unique.", kTissueRequired);
  tissue["properties"]["patch"] = ref("patch");
  tissue["properties"]["mesh"] = ref("mesh");
  tissue["properties"]["material"] = {{"type", "object"}, {"description", section_doc(kTissueSections, "material")}};
  tissue["properties"]["anchors"] = {{"type", "array"},
                                     {"description", section_doc(kTissueSections, "anchors")},
                                     {"items", {{"type", "integer"}, {"minimum", 0}}}};
  tissue["oneOf"] = json::array({{{"required", {"patch"}}}, {{"required", {"mesh"}}}});
  // The material table follows the model (charged_particles when `model` is left out).
  tissue["if"] = {{"properties", {{"model", {{"const", "mass_spring"}}}}}, {"required", {"model"}}};
  tissue["then"] = {{"properties", {{"material", ref("spring_material")}}}};
  tissue["else"] = {{"properties", {{"material", ref("charged_material")}}}};
  defs["tissue"] = tissue;

  json root = {{"$schema", "https://json-schema.org/draft/2020-12/schema"},
               {"$id", "https://palpate.dev/schema/scene.schema.json"},
               {"title", "palpate scene"}};
  root.update(object_schema<SceneDef>("A palpate scene (docs/scene-format.md)."));
  for (const char* section : {"tool", "device", "camera", "anatomy", "probe", "grasper"})
    root["properties"][section] = ref(section);
  root["properties"]["tissues"] = {{"type", "array"},
                                   {"description", section_doc(kSceneSections, "tissues")},
                                   {"minItems", 1},
                                   {"items", ref("tissue")}};
  root["anyOf"] = json::array({{{"required", {"tissues"}}}, {{"required", {"anatomy"}}}});
  root["$defs"] = defs;
  return root.dump(2) + "\n";
}

}  // namespace palpate
