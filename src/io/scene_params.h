// scene_params.h — internal: the scene file's sections, their hand-handled keys, and helpers that
// the YAML parser (scene_yaml.cpp) and the reference renderer (scene_params.cpp) share.
#pragma once

#include <palpate/scene_def.h>

#include <span>
#include <string>

namespace palpate {

// A key whose value is a mapping or a list, parsed by hand rather than through a table row.
struct SectionKey {
  const char* key;
  const char* type;  // as shown in the reference: "mapping", "list of ...", ...
  const char* doc;
};

// The hand-handled and the required keys of each section (the parser checks them; the reference
// documents them). Keep the parser in scene_yaml.cpp in step when adding one.
inline constexpr SectionKey kSceneSections[] = {
    {"tool", "mapping", "the tool held through the device (section `tool`)"},
    {"device", "mapping", "the haptic device that moves the tool (section `device`)"},
    {"camera", "mapping", "optional viewpoint for drawing (section `camera`)"},
    {"anatomy", "mapping", "optional generated anatomy, a neck (section `anatomy`)"},
    {"probe", "mapping", "optional ultrasound probe with its own device (section `probe`); needs `anatomy`"},
    {"grasper", "mapping",
     "optional grasper in the other hand, with its own device (section `grasper`): it presses and grasps "
     "mass-spring tissues as the tool does; not with a `probe`"},
    {"tissues", "list of mappings", "the tissues (section `tissues[]`); at least one, or an `anatomy`"},
};
// No key is required at the top level by the table: 'tissues' or 'anatomy' is checked by hand.

inline constexpr SectionKey kDeviceSections[] = {
    {"waypoints", "list of mappings",
     "scripted: timed positions `{t, position}`, optionally `direction`, times non-decreasing "
     "(section `device.waypoints[]`)"},
};
inline constexpr SectionKey kAnatomySections[] = {
    {"layers", "mapping",
     "a generated layer's material changed from its calibrated default: keys `skin`, `fat`, `ijv`, `cca`, each a "
     "mapping of charged_particles material keys (section `tissues[].material`); the keys it leaves out keep the "
     "default (docs/cvc.md)"},
};
inline constexpr SectionKey kProbeSections[] = {
    {"device", "mapping", "the probe's device, as the top-level `device` (section `device`)"},
};
inline constexpr SectionKey kGrasperSections[] = {
    {"device", "mapping", "the grasper's device, as the top-level `device` (section `device`); its waypoints' "
                          "`grasp` closes the jaws"},
};
inline constexpr const char* kWaypointRequired[] = {"t", "position"};

inline constexpr SectionKey kTissueSections[] = {
    {"patch", "mapping", "a generated patch (section `tissues[].patch`); exactly one of patch and mesh"},
    {"mesh", "mapping", "a mesh file (section `tissues[].mesh`); exactly one of patch and mesh"},
    {"material", "mapping", "the model's material (sections `tissues[].material`)"},
    {"anchors", "list of integers", "0-based indices of fixed particles or vertices"},
};
inline constexpr const char* kTissueRequired[] = {"name"};
inline constexpr const char* kMeshRequired[] = {"file"};

// What the alternatives of Param<Def>::Field hold, in the variant's order.
enum class FieldKind { number, integer, boolean, vec3, string, path };

// "number", "integer", "bool", "[x, y, z]", "string", "path".
const char* field_kind_name(FieldKind kind);
// A number as the messages and the reference print it: shortest form that reads back exactly.
std::string format_number(double x);
// The valid range of a number: "[1e-05, 0.1] s", ">= 0 N", "any" (unit "" = dimensionless).
std::string range_text(double min, double max, const char* unit);
// The choices "a|b|c" as "a, b, c".
std::string choices_text(const char* choices);

}  // namespace palpate
