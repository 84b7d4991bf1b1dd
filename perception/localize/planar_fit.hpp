// The closed-form planar rigid fit (Umeyama's least squares restricted to a turn about z).
#pragma once

#include <vector>

#include "core/geometry.hpp"

namespace weldtwin {

/// The rotation about z and translation in x, y that best move `from` onto `to` (pairs, least squares,
/// closed form by SVD of the 2x2 cross-covariance). Returns the transform applied to `from`.
Iso3 planar_rigid_fit(const std::vector<Vec3>& from, const std::vector<Vec3>& to);

}  // namespace weldtwin
