// palpate/anatomy.h — generated anatomy: the CVC scene's neck (skin, fat, internal jugular vein,
// common carotid artery) built as charged-particle tissues from a few published parameters.
#pragma once

#include <palpate/core.h>
#include <palpate/scene_def.h>

#include <string>
#include <vector>

namespace palpate {

// A vessel as a straight tube: the lumen is every point within `radius` of the axis.
struct VesselGeometry {
  Vec3 axis_point = Vec3::Zero();  // m, a point on the axis
  Vec3 axis = Vec3::UnitZ();       // unit
  double radius = 0;               // m
  bool contains(const Vec3& p) const {
    const Vec3 d = p - axis_point;
    return (d - d.dot(axis) * axis).squaredNorm() < radius * radius;
  }
};

// The neck's layers as scene tissues, outside in: skin, fat, ijv (role vein), cca (role artery),
// with the calibrated materials of docs/cvc.md. Errors name `where` and the key.
Result<std::vector<TissueDef>> neck_tissues(const NeckDef& neck, const std::string& where = "anatomy");

// The scene with its anatomy's tissues generated (neck_tissues, with anatomy.layers' materials
// applied) in front of its own; unchanged when it has no anatomy or is expanded already. Errors
// (a neck that cannot be built, a material rule that spans keys, a tissue named as a generated
// layer) name the scene's file, line and key. Simulation::build calls it; so may a front end that
// needs the tissue list first.
Result<SceneDef> expand_anatomy(const SceneDef& scene);

// Where the neck's vessels are (their rest geometry) and the skin's height at a given x.
VesselGeometry neck_vein(const NeckDef& neck);
VesselGeometry neck_artery(const NeckDef& neck);
double neck_skin_height(const NeckDef& neck, double x);

}  // namespace palpate
