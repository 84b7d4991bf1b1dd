// A prepared part kept between runs: the part model's built fields (samples, visibility, thickness, edge
// distances, footprint, outline, the faces continued past their edges) and its resting mesh in one file,
// named by a key of everything they are made of. The next localization of the same part reads them instead of
// building them (about a quarter of a localization's work); the lookups are made afresh (make_lookups).
//
// The key covers the mesh, its lift, every field of the model's setting, the file's format and the running
// program's build id (another build may build another model): a file of any other key is not read. A file is
// written whole under another name and then renamed, so that a reader (another run, at the same time) sees
// the old file or the new one, never half of one; a damaged file fails its checksum and is built again.
#pragma once

#include <cstdint>
#include <string>

#include "perception/localize/part_model.hpp"

namespace weldtwin {

/// The key of the model of `mesh` lifted by -min_z under `setting`, built by this program. 0 when the
/// program has no build id to tell its builds apart (then nothing is kept).
uint64_t part_model_key(const Mesh& mesh, double min_z, const PartModelSetting& setting);

/// The file that holds the model of `key` in `dir`.
std::string part_model_path(const std::string& dir, uint64_t key);

/// Writes the built fields of `model` and its resting mesh `rest` to `path` (its folder made when missing),
/// and removes the oldest model files of that folder beyond `keep_files`. Returns "" or why it could not.
std::string save_part_model(const PartModel& model, const Mesh& rest, uint64_t key, const std::string& path,
                            int keep_files = 64);

enum class PartFileRead {
  kRead,      ///< `model` and `rest` hold the file's fields (make_lookups is the caller's)
  kMissing,   ///< no such file
  kOtherKey,  ///< a file of another format, program build or part
  kDamaged,   ///< cut short, altered, or its fields do not fit together
};

/// Reads what save_part_model wrote under `key`. Unless kRead, `model` and `rest` are left as they were.
PartFileRead load_part_model(const std::string& path, uint64_t key, PartModel& model, Mesh& rest);

// The answers of the model's lookup grids asked so far (the nearest samples, PartModel::nearest, and the
// faces near each cell, ClosestGrid): they do not depend on the scan, and a part's scans ask about much the
// same places, so that a run can start with the answers of the runs before. Beside the model's file, under
// the same key.

/// The parsers of the files' bodies (what follows the header, before the checksum), for the fuzz harness:
/// false when the body is cut short, too long, or its fields do not fit together (the model's, the grid's
/// bricks, each slot empty or a sample's answer); then the model (and `rest`) are left as they were.
bool read_part_model_body(const char* data, size_t size, PartModel& model, Mesh& rest);
bool read_part_lookups_body(const char* data, size_t size, PartModel& model, size_t faces);

/// The lookups' file beside the model's file `part_path`.
std::string part_lookups_path(const std::string& part_path);

/// Writes the grids' bricks and cells made so far, and removes the oldest such files of the folder beyond
/// `keep_files`. Returns "" or why not.
std::string save_part_lookups(const PartModel& model, uint64_t key, const std::string& path,
                              int keep_files = 64);

/// Puts the answers of the file into the model's grids (made by make_lookups; `faces`: how many faces its
/// resting mesh has). Unless kRead, the grids are left as they were.
PartFileRead load_part_lookups(const std::string& path, uint64_t key, PartModel& model, size_t faces);

}  // namespace weldtwin
