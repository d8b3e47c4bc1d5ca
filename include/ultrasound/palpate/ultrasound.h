// palpate/ultrasound.h — the CVC scene's ultrasound: the neck pressed by a linear probe (an elastic
// half-space with the vessels as collapsible tubes under their own pressure) and the B-mode image of
// the plane under the probe (convolution of a scatterer field that moves with the tissue with the
// probe's point-spread function; Gao et al. 2009, Bürger et al. 2013). docs/ultrasound.md.
#pragma once

#include <palpate/core.h>
#include <palpate/anatomy.h>
#include <palpate/contact.h>
#include <palpate/scene_def.h>

#include <complex>
#include <cstdint>
#include <limits>
#include <filesystem>
#include <span>
#include <vector>

namespace palpate {

// Where the probe is: the centre of its footprint face and the device's orientation (identity: the
// probe faces ProbeDef::axis with its array along ProbeDef::lateral).
struct ProbePose {
  Vec3 position = Vec3::Zero();
  Quat orientation = Quat::Identity();
};

// The needle as the image sees it: its tip, the unit direction it points (handle to tip), its size.
struct NeedlePose {
  bool present = false;
  Vec3 tip = Vec3::Zero();
  Vec3 axis = Vec3(0, -1, 0);
  double radius = 0.00065;  // m (18 G: 1.3 mm outer diameter)
  double length = 0.064;    // m
};

// A vessel as the probe leaves it, in one cross-section: an ellipse (a circle when round).
struct VesselSection {
  Vec3 centre = Vec3::Zero();       // m, displaced with the tissue
  Vec3 axis = Vec3::UnitZ();        // unit, the vessel's axis
  Vec3 minor_dir = Vec3::UnitY();   // unit, ⟂ axis: the direction it is flattened along
  double a = 0, b = 0;              // m, semi-axes across (a) and along minor_dir (b); a ≥ b
  double rest_radius = 0;           // m, the scene's radius (no probe, mean pressure)
  double external_pressure = 0;     // Pa, the probe's stress on it (compressive > 0)
  double transmural_pressure = 0;   // Pa, inside minus outside
  double area_ratio = 1;            // area over the rest area
  bool contains(const Vec3& p) const noexcept;
};

// The neck under the probe: quasi-static, so every quantity is a function of the probe's pose and
// the time (the arterial pulse). Cheap (microseconds) and stateless: the haptic thread asks for the
// probe's force, an image thread for the deformation, without sharing anything.
class NeckCompression final : public ToolForceModel {
 public:
  NeckCompression(const NeckDef& neck, const ProbeDef& probe);

  // Force on the probe (N): the skin pushing back on the footprint's indentation, along the skin's
  // normal (frictionless). Haptic thread: noexcept, no allocation; about a microsecond.
  Vec3 force(const Vec3& position, const Quat& orientation, double t) noexcept override;
  Vec3 probe_force(const ProbePose& pose) const noexcept;
  // Where the tissue now at x lay at rest under the pose of the last force() call (ToolForceModel):
  // the needle's layers, built at rest, meet the neck the probe has deformed. Haptic thread.
  bool to_rest(const Vec3& x, Vec3& X) const noexcept override;

  // The deformation the probe causes at time t.
  struct State {
    double indentation = 0;            // m, mean depth of the footprint below the rest skin (≥ 0)
    double force = 0;                  // N, the probe's load on the neck
    Vec3 load_point = Vec3::Zero();    // m, the load's centroid on the skin
    Vec3 load_dir = Vec3(0, -1, 0);    // unit, the direction the load pushes (the probe's beam)
    static constexpr int kLoads = 27;  // 9 × 3 point loads over the footprint
    Vec3 load_at[kLoads];              // m
    double load[kLoads] = {};          // N
    double displacement_scale = 0;     // the half-space sum's factor that sinks the skin by `indentation`
    double time = 0;                   // s, the arterial pulse's clock
    VesselSection vein, artery;        // in the cross-section through the footprint's centre
  };
  State state(const ProbePose& pose, double t) const noexcept;
  // The vessel's section at position z along it (the probe loads it unevenly along its length).
  VesselSection vein_at(const State& s, const Vec3& along) const noexcept;
  VesselSection artery_at(const State& s, const Vec3& along) const noexcept;
  // Displacement of the tissue at rest point X by the probe's load (half-space part only, m).
  Vec3 displacement(const State& s, const Vec3& X) const noexcept;
  // Vertical (along the load) normal stress at X (Pa, compressive > 0).
  double stress(const State& s, const Vec3& X) const noexcept;
  // The inverse of the deformation the image draws: the rest point X of the tissue now at x. The
  // half-space's displacement inverted by fixed-point iteration (x = X + u(X)); near a vessel, its
  // section mapped back onto its rest circle — the deformed wall onto the rest wall, the lumen onto
  // the rest lumen, a point outside at its distance from the wall — blended into the half-space's
  // map over two rest radii. So a needle meets the vessel's wall in its charged-particle layer
  // exactly where the image shows the compressed wall, and is in its lumen exactly when the image
  // shows the tip inside it. Allocation-free; a few microseconds near the vessels.
  Vec3 rest_point(const State& s, const Vec3& x) const noexcept;

  const NeckDef& neck() const noexcept { return neck_; }
  const ProbeDef& probe() const noexcept { return probe_; }
  double contact_stiffness() const noexcept { return stiffness_; }  // N/m, the footprint's

  // The probe's frame for a pose: beam (into the tissue), lateral (along the array), elevation.
  struct Frame {
    Vec3 origin, beam, lateral, elevation;
  };
  Frame frame(const ProbePose& pose) const noexcept;

 private:
  State loads(const ProbePose& pose) const noexcept;  // the footprint's loads only (haptic thread)
  State posed(const ProbePose& pose, double t) const noexcept;  // loads, the displacement's scale, the time
  VesselSection section_geometry(const State& s, const Vec3& rest_centre, const Vec3& along, double radius) const noexcept;
  void section_law(VesselSection& v, bool vein, double t) const noexcept;  // its tube law at time t
  VesselSection section(const State& s, const Vec3& rest_centre, const Vec3& along, double radius,
                        bool vein, double t) const noexcept;
  NeckDef neck_;
  ProbeDef probe_;
  double stiffness_ = 0;  // N/m
  double pulse_mean_ = 0; // the pulse shape's mean over a beat
  VesselGeometry vein_geometry_, artery_geometry_;  // at rest
  State posed_;           // the last force() call's (to_rest); its force 0 until then
  // to_rest's vessel sections, reused for points within 0.1 mm along the vessels (the tip and the
  // point behind it each tick) while the pose is the same. Haptic thread only.
  struct SectionCache {
    std::uint64_t pose = 0;  // the pose's generation now
    struct Slot {
      std::uint64_t pose = 0;  // the generation it was taken at; 0 = empty
      double along = 0;        // m, the rest axial coordinate it was taken at
      VesselSection geometry;  // section_geometry's part (no tube law)
    } slots[2][2];             // [vessel][two places along it: the tip and where the shaft enters]
    int next[2] = {0, 0};
    Vec3 last_x = Vec3::Constant(std::numeric_limits<double>::quiet_NaN()), last_X = Vec3::Zero();
  };
  std::uint64_t posed_generation_ = 0;
  ProbePose posed_pose_;
  mutable SectionCache cache_;
  Vec3 rest_point(const State& s, const Vec3& x, SectionCache* cache) const noexcept;
};

// A B-mode image: 8-bit grey, row 0 at the probe's face; and the envelope before log compression.
struct UltrasoundImage {
  int width = 0, height = 0;
  double pixel_width = 0, pixel_depth = 0;  // m
  std::vector<std::uint8_t> grey;           // width × height, row-major
  std::vector<float> envelope;              // width × height, linear, after attenuation and TGC
  bool in_contact = false;                  // any column coupled to the skin
};

// Makes B-mode images of the neck. Construction precomputes the point-spread function; render()
// allocates only the first time (the image's buffers, reused after). One imager per thread.
class UltrasoundImager {
 public:
  UltrasoundImager(const NeckDef& neck, const ProbeDef& probe);
  void render(const ProbePose& probe, const NeedlePose& needle, double t, UltrasoundImage& out);
  // The vein's wall as the needle's tissue has it now: the `vein` tissue's particles at rest and now
  // (snapshots, point for point; the run's first snapshot is its rest). The image then shows the wall
  // tented where the needle pushes it, on top of the probe's compression. Empty spans: no tenting.
  void set_vein_wall(std::span<const Vec3f> rest, std::span<const Vec3f> now);
  // World point of pixel (column, row) centres (fractional allowed) for a probe pose.
  Vec3 pixel_position(const ProbePose& probe, double column, double row) const noexcept;
  const NeckCompression& neck() const noexcept { return model_; }

 private:
  NeckCompression model_;
  std::vector<float> axial_kernel_;                // the PSF along the beam (pixels)
  std::vector<std::vector<float>> lateral_kernel_; // the PSF across, per row (widens off focus)
  std::vector<std::complex<float>> field_, tmp_;   // scratch
  std::vector<double> tgc_;                        // scratch: time-gain compensation per row
  std::vector<Vec3f> wall_rest_, wall_now_;        // the vein wall's particles (set_vein_wall)
  std::vector<Vec3> rest_;                         // scratch: the inverse displacement map's grid
  std::vector<int> row_cell_;                      // scratch: per row, the rest map's grid row below
  std::vector<double> row_weight_;                 // scratch: per row, the grid row above's weight
  std::vector<float> pad_, rows_, lateral_out_;    // scratch: the PSF's zero-padded lines (re, im)
};

// Write an ultrasound image as an 8-bit grey PNG (atomically, via <file>.part).
Status write_ultrasound_png(const UltrasoundImage& image, const std::filesystem::path& file);

// What render() burns into the grey image (not the envelope), as a scanner shows it: the depth
// scale on the right edge — a tick every 5 mm from the probe's face (kDepthTickShort pixels long,
// every 10 mm kDepthTickLong), white edged in black — and the orientation marker, a white square
// kMarkerSide pixels wide at the top left: the image's left is the probe's −lateral end
// (ProbeDef::lateral runs from the image's left to its right).
inline constexpr int kDepthTickShort = 4, kDepthTickLong = 8, kMarkerSide = 4;
void draw_ultrasound_overlay(UltrasoundImage& image) noexcept;

}  // namespace palpate
