// A mesh cut into pieces whose convex hulls follow it. MuJoCo collides a mesh geom as its convex hull; a
// link whose mesh is long and uneven (a shoulder housing, a tube, an elbow housing) has a hull much fuller
// than the link. Cut into slabs across its longest side, each slab's hull holds only the mesh within it.
#pragma once

#include <vector>

#include "core/mesh_file.hpp"

namespace weldtwin {

struct ConvexPiecesSetting {
  /// A slab is at most this thick; a mesh no longer than this stays one piece.
  double max_slab_m = 0.05;
};

/// The mesh's points per slab: the vertices within it and where its triangles cross the slab's faces, in the
/// mesh's frame. The slabs' hulls together hold every triangle of the mesh (each triangle's part within a
/// slab lies in that slab's hull). A slab with too few points to span a volume (a flat cap) is merged into
/// its neighbour.
std::vector<std::vector<Vec3>> convex_pieces(const Mesh& mesh, const ConvexPiecesSetting& setting = {});

}  // namespace weldtwin
