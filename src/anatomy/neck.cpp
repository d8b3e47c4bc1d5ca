// neck.cpp — the CVC scene's neck from parameters: skin and fat on a curved neck surface, the
// internal jugular vein and the common carotid artery as two-sided tubes (docs/cvc.md).
#include <palpate/anatomy.h>

#include <cstdlib>
#include <variant>

#include <cmath>
#include <sstream>

namespace palpate {

namespace {

constexpr double kPi = 3.14159265358979323846;

std::string num(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

// The vessels' patches leave 5 % of the circumference open (a charged patch is a lattice, not a
// ring); the seam faces away from the needle's path: the vein's laterally and a little down, the
// artery's medially and a little down. Both normals keep |n.x| < 0.9, so the patch frame puts the
// tube's axis along z (frame() in src/tissue/charged/model.cpp).
const Vec3 kVeinNormal = Vec3(-2, 1, 0).normalized();   // medial and up
const Vec3 kArteryNormal = Vec3(2, 1, 0).normalized();  // lateral and up
constexpr double kClosed = 0.95;

// Calibrated materials (docs/cvc.md, "Calibration"); the thickness of skin and fat follows the
// geometry.
ChargedMaterialDef skin_material(const NeckDef& n) {
  ChargedMaterialDef m;
  m.puncture_force = 1.22;      // N, median skin puncture force over 24 studies (van Gerwen 2012)
  m.max_displacement = 0.005;   // m, tenting before the skin gives (chosen; no neck figure)
  m.linear_share = 0.3;
  m.elasticity = 30;
  m.max_strain = 0.5;
  m.thickness = n.skin_thickness;
  m.friction_per_length = 60;   // N/m: with the fat's, ~20 % of the insertion force (Barnett 2015)
  return m;
}

ChargedMaterialDef fat_material(const NeckDef& n) {
  ChargedMaterialDef m;
  m.puncture_force = 0.3;       // N, little cutting resistance (fat ≈ 3 kPa against skin's ≥ 50 kPa)
  m.max_displacement = 0.003;
  m.linear_share = 0.5;
  m.elasticity = 10;
  m.max_strain = 0.8;
  m.thickness = n.ijv_depth - n.skin_thickness;
  m.friction_per_length = 15;
  return m;
}

ChargedMaterialDef vein_material(const NeckDef& n) {
  ChargedMaterialDef m;
  m.puncture_force = 0.5;       // N, a small distinct second pop (design value, see docs/cvc.md)
  // The anterior wall tents in by 40 % of the diameter before it gives: the lumen's cross-section
  // halves under the advancing needle (1.57 → 0.75 cm², Mallory et al. 1990).
  m.max_displacement = 0.4 * n.ijv_diameter;
  m.linear_share = 0.3;
  m.elasticity = 20;
  m.max_strain = 0.5;
  m.two_sided = true;           // punctured in, and out through the back wall
  m.thickness = 0.0006;         // m, the wall
  m.friction_per_length = 30;
  return m;
}

ChargedMaterialDef artery_material() {
  ChargedMaterialDef m;
  m.puncture_force = 1.0;       // N, stiffer than the vein (CCA E ≈ 0.7–1 MPa, Riley 1992)
  m.max_displacement = 0.002;   // m, it barely yields
  m.linear_share = 0.5;
  m.elasticity = 40;
  m.max_strain = 0.3;
  m.two_sided = true;
  m.thickness = 0.0008;
  m.friction_per_length = 40;
  return m;
}

TissueDef tube(const std::string& name, const std::string& role, const VesselGeometry& g, const Vec3& normal,
               double length, double spacing, const ChargedMaterialDef& mat) {
  TissueDef t;
  t.name = name, t.role = role, t.model = "charged_particles";
  PatchDef p;
  p.shape = "cylinder", p.radius = g.radius, p.width = kClosed * 2 * kPi * g.radius, p.height = length;
  p.spacing = spacing, p.center = g.axis_point + g.radius * normal, p.normal = normal;
  t.patch = p;
  t.charged = mat;
  return t;
}

}  // namespace

double neck_skin_height(const NeckDef& n, double x) {
  return std::sqrt(std::max(0.0, n.neck_radius * n.neck_radius - x * x)) - n.neck_radius;
}

VesselGeometry neck_vein(const NeckDef& n) {
  VesselGeometry g;
  g.radius = n.ijv_diameter / 2;
  g.axis_point = Vec3(n.ijv_x, neck_skin_height(n, n.ijv_x) - n.ijv_depth - g.radius, 0);
  return g;
}

VesselGeometry neck_artery(const NeckDef& n) {
  const VesselGeometry v = neck_vein(n);
  VesselGeometry g;
  g.radius = n.cca_diameter / 2;
  const double a = n.cca_angle * kPi / 180, d = v.radius + n.cca_gap + g.radius;
  g.axis_point = v.axis_point + d * Vec3(-std::cos(a), -std::sin(a), 0);
  return g;
}

Result<std::vector<TissueDef>> neck_tissues(const NeckDef& n, const std::string& where) {
  if (n.kind != "neck") return Error{where + ": kind '" + n.kind + "' is not known; expected neck"};
  if (!(n.skin_thickness < n.ijv_depth))
    return Error{where + ": skin_thickness (" + num(n.skin_thickness) + " m) must be less than ijv_depth (" +
                 num(n.ijv_depth) + " m): the vein lies under the skin"};
  // The vein's far wall inside the region's half width: |x| + its radius (not its diameter).
  if (!(std::abs(n.ijv_x) + n.ijv_diameter / 2 < n.width / 2))
    return Error{where + ": the vein (ijv_x " + num(n.ijv_x) + " m, diameter " + num(n.ijv_diameter) +
                 " m) must lie inside the region's width " + num(n.width) + " m"};
  if (!(n.width < n.neck_radius * kPi))
    return Error{where + ": width (" + num(n.width) + " m) must be less than half the neck's circumference (" +
                 num(n.neck_radius * kPi) + " m)"};
  const VesselGeometry vein = neck_vein(n), artery = neck_artery(n);
  const double bottom = std::min(vein.axis_point.y() - vein.radius, artery.axis_point.y() - artery.radius);
  if (bottom < -n.neck_radius)
    return Error{where + ": the vessels reach " + num(-bottom) + " m deep, past the neck's radius " +
                 num(n.neck_radius) + " m"};
  std::vector<TissueDef> out;
  TissueDef skin;
  skin.name = "skin", skin.role = "skin", skin.model = "charged_particles";
  PatchDef sp;
  sp.shape = "cylinder", sp.radius = n.neck_radius, sp.width = n.width, sp.height = n.length;
  sp.spacing = n.spacing, sp.center = Vec3::Zero(), sp.normal = Vec3::UnitY();
  skin.patch = sp;
  skin.charged = skin_material(n);
  out.push_back(skin);
  TissueDef fat = skin;
  fat.name = "fat", fat.role = "fat";
  fat.patch->radius = n.neck_radius - n.skin_thickness;
  fat.patch->center = Vec3(0, -n.skin_thickness, 0);
  fat.charged = fat_material(n);
  out.push_back(fat);
  out.push_back(tube("ijv", "vein", vein, kVeinNormal, n.length, n.vessel_spacing, vein_material(n)));
  out.push_back(tube("cca", "artery", artery, kArteryNormal, n.length, n.vessel_spacing, artery_material()));
  return out;
}

Result<SceneDef> expand_anatomy(const SceneDef& scene) {
  if (!scene.anatomy || scene.anatomy_expanded) return scene;
  const NeckDef& n = *scene.anatomy;
  const std::string& file = n.file;
  const int line = n.line;
  auto made = neck_tissues(n, file + ":" + std::to_string(line) + ": anatomy");
  if (!made) return made.error();
  for (TissueDef& t : *made) t.line = line;
  // Each layer's material keys the scene set, over the calibrated default.
  for (const AnatomyLayerDef& layer : n.layers) {
    TissueDef* t = nullptr;
    for (TissueDef& g : *made)
      if (g.name == layer.name) t = &g;
    if (!t) return Error{file + ":" + std::to_string(layer.line) + ": anatomy.layers." + layer.name +
                         ": not a layer of the neck; expected skin, fat, ijv or cca"};
    for (const std::string& key : layer.keys)
      for (const Param<ChargedMaterialDef>& p : param_table(static_cast<const ChargedMaterialDef*>(nullptr)))
        if (key == p.key)
          std::visit([&](auto member) { t->charged.*member = layer.material.*member; }, p.field);
    t->line = layer.line;
    // The rule that spans the material and the generated patch, as for a tissue of the scene's own.
    if (t->charged.max_separation > 0 && !(t->charged.max_separation > t->patch->spacing))
      return Error{file + ":" + std::to_string(layer.line) + ": anatomy.layers." + layer.name + ".max_separation: " +
                   num(t->charged.max_separation) + " m must exceed the layer's spacing " + num(t->patch->spacing) +
                   " m (or leave it 0 and set max_strain)"};
  }
  SceneDef out = scene;
  for (const TissueDef& own : scene.tissues)
    for (const TissueDef& g : *made)
      if (own.name == g.name)
        return Error{file + ":" + std::to_string(own.line) + ": tissues: duplicate tissue name '" + own.name +
                     "' (the anatomy on line " + std::to_string(line) + " generates it)"};
  out.tissues = std::move(*made);
  out.tissues.insert(out.tissues.end(), scene.tissues.begin(), scene.tissues.end());
  out.anatomy_expanded = true;
  return out;
}

}  // namespace palpate
