#pragma once
// From raw Sensel counts to physical units, as documented, deterministic
// functions (protocol spec §6 upsampling, §7 units). The store keeps raw counts
// on the native grid; these run on read and export.
//
// Units: counts / 2^unit_shift (3 on the Morph) = grams on one native cell
// (2.5 x 2.5 mm at high detail, 5 x 5 mm at medium). Newtons = g x 9.80665e-3.
// Pressure on a native cell: N / cell area. The 185 x 105 image interpolated from
// the native grid spreads one cell's force over xscale x yscale sensels, so its
// per-sensel pressure divides by that factor as well.
#include <array>
#include <cstdint>
#include <vector>

#include "codec/sensel_pressure_codec.h"

namespace pvcap::sensel {

inline constexpr double kSenselPitchMm = 1.25;
inline constexpr double kStandardGravity = 9.80665;
inline constexpr int kMorphForceUnitShift = 3;  // register 0xA1

constexpr double counts_to_grams(double counts, int unit_shift = kMorphForceUnitShift) {
  return counts / double(1 << unit_shift);
}
constexpr double grams_to_newtons(double grams) { return grams * kStandardGravity * 1e-3; }
// Area of one native cell, m^2.
constexpr double native_cell_area_m2(const Grid& g) {
  return (kSenselPitchMm * g.xscale * 1e-3) * (kSenselPitchMm * g.yscale * 1e-3);
}
// Pressure (kPa) on one native cell carrying `counts`.
constexpr double native_cell_kpa(double counts, const Grid& g, int unit_shift = kMorphForceUnitShift) {
  return grams_to_newtons(counts_to_grams(counts, unit_shift)) / native_cell_area_m2(g) / 1000.0;
}
// Pressure (kPa) on one sensel of the upsampled image holding `counts` (interpolated).
constexpr double upsampled_sensel_kpa(double counts, const Grid& g, int unit_shift = kMorphForceUnitShift) {
  return grams_to_newtons(counts_to_grams(counts, unit_shift)) / ((kSenselPitchMm * 1e-3) * (kSenselPitchMm * 1e-3)) /
         double(g.xscale * g.yscale) / 1000.0;
}

// What a pressure frame amounts to: total force, contact (cells above `contact_kpa`, the
// paper's contact threshold being 1 kPa) and the force-weighted centre, in sensor mm from the
// centre of sensel (0, 0). Computed on the native grid the device sends.
struct PressureSummary {
  double total_newtons = 0;
  double contact_area_mm2 = 0;
  int contact_cells = 0;
  double centroid_x_mm = 0, centroid_y_mm = 0;  // meaningful when total_newtons > 0
};
PressureSummary summarize_pressure(const std::vector<std::uint16_t>& counts, const Grid& g, double contact_kpa = 1.0,
                                   int unit_shift = kMorphForceUnitShift);

// The 4-tap weights for fractional position t = step/scale (taps at seg-1, seg, seg+1, seg+2):
// tent-weighted integral of the window (1-(t-s)^2)^2 over s in [-1, 2], normalised,
// evaluated as a Riemann sum with step 0.001, as the device library does.
std::array<double, 4> upsampling_weights(double t);

// Expands raw counts on `g` (row-major, cols x rows) to out_cols() x out_rows() (185 x 105),
// separably (x, then y). Taps outside the grid are dropped without renormalising, as in the
// only public description; edge sensels come out ~16 % low (unconfirmed for the device library).
std::vector<float> upsample(const std::vector<std::uint16_t>& counts, const Grid& g);

}  // namespace pvcap::sensel
