#include "sim/renderer.hpp"

#include <png.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <optional>
#include <stdexcept>

#include "sim/gl_context.hpp"

namespace weldtwin {

std::vector<uint8_t> Image::png() const {
  png_image img;
  std::memset(&img, 0, sizeof img);
  img.version = PNG_IMAGE_VERSION;
  img.width = static_cast<png_uint_32>(width);
  img.height = static_cast<png_uint_32>(height);
  img.format = PNG_FORMAT_RGB;
  png_alloc_size_t size = 0;
  if (!png_image_write_to_memory(&img, nullptr, &size, 0, rgb.data(), 0, nullptr))
    throw std::runtime_error(std::string("PNG: ") + img.message);
  std::vector<uint8_t> out(size);
  if (!png_image_write_to_memory(&img, out.data(), &size, 0, rgb.data(), 0, nullptr))
    throw std::runtime_error(std::string("PNG: ") + img.message);
  out.resize(size);
  return out;
}

void Image::write_png(const std::string& path) const {
  const std::vector<uint8_t> bytes = png();
  std::ofstream out(path, std::ios::binary);
  if (!out) throw std::runtime_error("cannot write " + path);
  out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
}

double Image::spread() const {
  if (rgb.empty()) return 0.0;
  double sum = 0, sum2 = 0;
  for (uint8_t v : rgb) {
    sum += v;
    sum2 += static_cast<double>(v) * v;
  }
  const double n = static_cast<double>(rgb.size()), mean = sum / n;
  return std::sqrt(std::max(0.0, sum2 / n - mean * mean));
}

struct OffscreenRenderer::Impl {
  const mjModel* model = nullptr;
  int width = 0, height = 0;
  std::optional<OffscreenGlContext> context;
  mjvScene scene;
  mjrContext gl;
  mjvOption option;
};

OffscreenRenderer::OffscreenRenderer(const mjModel* model, int width, int height)
    : impl_(std::make_unique<Impl>()) {
  if (width > model->vis.global.offwidth || height > model->vis.global.offheight)
    throw std::invalid_argument("renderer: the model's offscreen buffer is smaller than the picture");
  Impl& r = *impl_;
  r.model = model;
  r.width = width;
  r.height = height;
  r.context.emplace(model->vis.global.offwidth, model->vis.global.offheight);
  mjv_defaultScene(&r.scene);
  mjv_makeScene(model, &r.scene, model->ngeom + 40000);
  mjr_defaultContext(&r.gl);
  mjr_makeContext(model, &r.gl, mjFONTSCALE_100);
  mjr_setBuffer(mjFB_OFFSCREEN, &r.gl);
  mjv_defaultOption(&r.option);
}

OffscreenRenderer::~OffscreenRenderer() {
  mjr_freeContext(&impl_->gl);
  mjv_freeScene(&impl_->scene);
  impl_->context.reset();
}

Image OffscreenRenderer::render(mjData* data, const View& view, const Overlay& overlay) {
  Impl& r = *impl_;
  r.context->make_current();
  mjvCamera cam;
  mjv_defaultCamera(&cam);
  if (!view.camera.empty()) {
    const int id = mj_name2id(r.model, mjOBJ_CAMERA, view.camera.c_str());
    if (id < 0) throw std::invalid_argument("renderer: the cell has no camera '" + view.camera + "'");
    cam.type = mjCAMERA_FIXED;
    cam.fixedcamid = id;
  } else {
    cam.type = mjCAMERA_FREE;
    for (int k = 0; k < 3; ++k) cam.lookat[k] = view.lookat[k];
    cam.distance = view.distance_m;
    cam.azimuth = view.azimuth_deg;
    cam.elevation = view.elevation_deg;
  }
  mj_camlight(r.model, data);  // fixed cameras and lights follow the kinematics
  mjv_updateScene(r.model, data, &r.option, nullptr, &cam, mjCAT_ALL, &r.scene);

  const int part_geom = mj_name2id(r.model, mjOBJ_GEOM, "part");
  int kept = 0;
  for (int g = 0; g < r.scene.ngeom; ++g) {
    mjvGeom& geom = r.scene.geoms[g];
    const bool is_geom = geom.objtype == mjOBJ_GEOM && geom.objid >= 0;
    if (is_geom && geom.objid == part_geom) geom.rgba[3] = overlay.part_alpha;
    if (is_geom && static_cast<size_t>(geom.objid) < overlay.hide_geom.size() &&
        overlay.hide_geom[static_cast<size_t>(geom.objid)])
      continue;
    if (is_geom && geom.objid == part_geom && overlay.part_alpha <= 0.0f) continue;
    r.scene.geoms[kept++] = geom;
  }
  r.scene.ngeom = kept;
  auto room = [&] { return r.scene.ngeom < r.scene.maxgeom; };
  const mjtNum eye[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  if (overlay.ghost_mesh >= 0 && room()) {
    mjvGeom& g = r.scene.geoms[r.scene.ngeom++];
    const Vec3 p = overlay.ghost_pose.translation();
    const Eigen::Matrix<double, 3, 3, Eigen::RowMajor> R = overlay.ghost_pose.linear();
    const mjtNum pos[3] = {p.x(), p.y(), p.z()};
    mjv_initGeom(&g, mjGEOM_MESH, nullptr, pos, R.data(), overlay.ghost_rgba.data());
    g.dataid = overlay.ghost_mesh;
    g.category = mjCAT_DECOR;
  }
  for (size_t i = 0; i < overlay.points.size() && room(); ++i) {
    mjvGeom& g = r.scene.geoms[r.scene.ngeom++];
    const mjtNum s[3] = {overlay.point_size_m, overlay.point_size_m, overlay.point_size_m};
    const mjtNum pos[3] = {overlay.points[i].x(), overlay.points[i].y(), overlay.points[i].z()};
    const Rgba& c = i < overlay.point_rgba.size() ? overlay.point_rgba[i] : Rgba{1, 1, 1, 1};
    mjv_initGeom(&g, mjGEOM_BOX, s, pos, eye, c.data());
    g.category = mjCAT_DECOR;
  }
  for (const auto& [a, b] : overlay.segments) {
    if (!room()) break;
    mjvGeom& g = r.scene.geoms[r.scene.ngeom++];
    mjv_initGeom(&g, mjGEOM_CAPSULE, nullptr, nullptr, nullptr, overlay.segment_rgba.data());
    mjv_makeConnector(&g, mjGEOM_CAPSULE, overlay.segment_width_m, a.x(), a.y(), a.z(), b.x(), b.y(), b.z());
    g.category = mjCAT_DECOR;
  }

  const mjrRect viewport{0, 0, r.width, r.height};
  mjr_render(viewport, &r.scene, &r.gl);
  Image img;
  img.width = r.width;
  img.height = r.height;
  std::vector<uint8_t> flipped(static_cast<size_t>(r.width) * static_cast<size_t>(r.height) * 3);
  mjr_readPixels(flipped.data(), nullptr, viewport, &r.gl);
  img.rgb.resize(flipped.size());
  const size_t row = static_cast<size_t>(r.width) * 3;
  for (int y = 0; y < r.height; ++y)  // OpenGL rows come bottom-up
    std::memcpy(img.rgb.data() + static_cast<size_t>(y) * row,
                flipped.data() + static_cast<size_t>(r.height - 1 - y) * row, row);
  return img;
}

}  // namespace weldtwin
