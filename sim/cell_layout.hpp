// Where things stand in a cell: the part pose, its clamps and clutter, from the cell file or drawn from a
// seed. Checks that a layout is physically possible: the part rests on the table, its seams are within reach,
// the clamps touch the part and stand on the table, nothing overlaps.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "core/cell_spec.hpp"
#include "core/part_spec.hpp"

namespace weldtwin {

/// A toggle clamp. Clamp frame: origin at the pad's contact point on the part, x horizontal towards the clamp
/// body, z up. The pad presses on the part's top face; the base stands on the table.
struct ClampPlacement {
  int site = 0;  ///< index into PartSpec::clamp_sites
  Iso3 T_base_clamp = Iso3::Identity();
  double grip_height_m = 0.0;  ///< height of the contact point above the table top
};

struct CellLayout {
  Iso3 T_base_part = Iso3::Identity();
  std::vector<ClampPlacement> clamps;
  std::vector<ClutterItem> clutter;
  std::optional<uint64_t> seed;  ///< set when the layout was drawn
};

/// The layout given by the cell file (seed unset) or drawn from the seed: part pose, 2-4 clamps, 0-3 clutter
/// items. Throws InputError naming the cell file for an impossible layout given in the file (out of reach,
/// intersecting the table, clamp off the table, overlaps).
CellLayout make_layout(const CellSpec& cell, const PartSpec& part, std::optional<uint64_t> seed);

/// The cell's layout with the part at T_base_part: the cell's clamp sites, its clutter (not checked: see
/// layout_problem). Throws InputError for a clamp site the part does not have.
CellLayout layout_at(const CellSpec& cell, const PartSpec& part, const Iso3& T_base_part);

/// The reason a layout is impossible, or "" when it is fine.
std::string layout_problem(const CellSpec& cell, const PartSpec& part, const CellLayout& layout);

}  // namespace weldtwin
