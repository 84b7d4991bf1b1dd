// The pose file (docs/design.md): where the part lies in the robot's base frame, T_base_part, and how far
// to trust it. `weldtwin localize` and `run` write it, `plan` and other tools read it.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "core/geometry.hpp"

namespace weldtwin {

struct PoseEstimate;

/// The pose JSON with every figure of the estimate.
nlohmann::json pose_to_json(const PoseEstimate& pose);

/// A pose JSON holding only T_base_part (the truth the twin placed the part at).
nlohmann::json true_pose_json(const Iso3& T_base_part);

/// T_base_part from a pose JSON; InputError naming the file (also when the pose says "not found").
Iso3 read_pose(const std::string& path);

}  // namespace weldtwin
