#include "sim/replay.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <stdexcept>
#include <thread>

#include "core/parallel_for.hpp"
#include "sim/collision_check.hpp"

namespace weldtwin {
namespace {

// Joint reference between 200 Hz samples: cubic Hermite through the samples with central-difference
// velocities, so that position, velocity and acceleration are all defined for the servos and feed-forward.
class JointReference {
 public:
  explicit JointReference(const std::vector<PlanSample>& s) : s_(s), v_(s.size(), JointVector::Zero()) {
    const size_t n = s.size();
    for (size_t k = 0; k < n; ++k) {
      if (n < 2) break;
      const size_t a = k == 0 ? 0 : k - 1, b = k + 1 == n ? n - 1 : k + 1;
      const double dt = s[b].t_s - s[a].t_s;
      if (dt > 0) v_[k] = (s[b].q - s[a].q) / dt;
    }
    v_.front().setZero();  // plans start and end at rest
    v_.back().setZero();
  }

  void at(double t, JointVector& q, JointVector& qd, JointVector& qdd) {
    while (k_ + 1 < s_.size() && s_[k_ + 1].t_s <= t) ++k_;
    if (k_ + 1 >= s_.size() || t <= s_.front().t_s) {
      q = t <= s_.front().t_s ? s_.front().q : s_.back().q;
      qd.setZero();
      qdd.setZero();
      return;
    }
    const double h = s_[k_ + 1].t_s - s_[k_].t_s;
    const double u = (t - s_[k_].t_s) / h;
    const JointVector &p0 = s_[k_].q, &p1 = s_[k_ + 1].q;
    const JointVector m0 = v_[k_] * h, m1 = v_[k_ + 1] * h;
    const double u2 = u * u, u3 = u2 * u;
    q = (2 * u3 - 3 * u2 + 1) * p0 + (u3 - 2 * u2 + u) * m0 + (-2 * u3 + 3 * u2) * p1 + (u3 - u2) * m1;
    qd =
        ((6 * u2 - 6 * u) * p0 + (3 * u2 - 4 * u + 1) * m0 + (-6 * u2 + 6 * u) * p1 + (3 * u2 - 2 * u) * m1) /
        h;
    qdd = ((12 * u - 6) * p0 + (6 * u - 4) * m0 + (-12 * u + 6) * p1 + (6 * u - 2) * m1) / (h * h);
  }

 private:
  const std::vector<PlanSample>& s_;
  std::vector<JointVector> v_;
  size_t k_ = 0;
};

std::string geom_name(const mjModel* m, int g) {
  const char* n = mj_id2name(m, mjOBJ_GEOM, g);
  return n ? n : "geom" + std::to_string(g);
}

std::string fmt(const char* f, double a, double b = 0.0) {
  char buf[160];
  std::snprintf(buf, sizeof buf, f, a, b);
  return buf;
}

}  // namespace

double distance_to_seam(const PartSpec& part, int seam, const Iso3& T_base_part, const Vec3& p) {
  return part.seams.at(static_cast<size_t>(seam)).distance_to(T_base_part.inverse() * p);
}

ReplayResult replay_plan(const MujocoWorld& world, const RobotModel& robot, const WeldPlan& plan,
                         const PartSpec& part, const Mesh& part_mesh, const Iso3& T_base_part_true,
                         const ReplaySetting& setting) {
  if (plan.samples.empty()) throw std::invalid_argument("replay: the plan has no samples");
  const auto t_start = std::chrono::steady_clock::now();
  install_mujoco_handlers();
  // The replay model: implicit integration at the replay step; the part takes no part in MuJoCo's contacts
  // (its collision shape would be its convex hull) — its exact mesh is checked below instead.
  ModelPtr model(mj_copyModel(nullptr, world.model()));
  mjModel* m = model.get();
  m->opt.timestep = setting.timestep_s;
  // Semi-implicit Euler, which integrates joint damping implicitly: the velocity servos' damping is given to
  // the joints (below), so the stiff loops stay stable without the implicit integrator's derivatives (which
  // cost a third of the step).
  m->opt.integrator = mjINT_EULER;
  for (int g = 0; g < m->ngeom; ++g)
    if (world.geom_label(g) == Label::kPart) m->geom_contype[g] = m->geom_conaffinity[g] = 0;
  // The feed-forward model: the arm alone, no contacts or limits (a controller knows only its own arm).
  ModelPtr ref_model(mj_copyModel(nullptr, m));
  ref_model->opt.disableflags |= mjDSBL_CONSTRAINT;
  DataPtr d(mj_makeData(m)), dref(mj_makeData(ref_model.get()));

  const int n = robot.dof();
  std::vector<int> dof(static_cast<size_t>(n)), servo(static_cast<size_t>(n)), damper(static_cast<size_t>(n));
  for (int j = 0; j < n; ++j) {
    const std::string& name = robot.joint_names()[static_cast<size_t>(j)];
    dof[static_cast<size_t>(j)] = m->jnt_dofadr[mj_name2id(m, mjOBJ_JOINT, name.c_str())];
    servo[static_cast<size_t>(j)] = mj_name2id(m, mjOBJ_ACTUATOR, ("servo_" + name).c_str());
    damper[static_cast<size_t>(j)] = mj_name2id(m, mjOBJ_ACTUATOR, ("damper_" + name).c_str());
    if (servo[static_cast<size_t>(j)] < 0 || damper[static_cast<size_t>(j)] < 0)
      throw std::logic_error("the cell model has no servo for joint " + name);
  }
  const int tcp_body = world.body("tcp");

  // Servo gains from each joint's inertia at the start pose: kp = I w^2, kv = 2 zeta I w.
  world.set_joints(d.get(), plan.samples.front().q);
  mj_forward(m, d.get());
  std::vector<mjtNum> M(static_cast<size_t>(m->nv * m->nv));
  mj_fullM(m, M.data(), d->qM);
  const double w = 2 * kPi * setting.bandwidth_hz;
  for (int j = 0; j < n; ++j) {
    const int v = dof[static_cast<size_t>(j)];
    const double inertia = M[static_cast<size_t>(v * m->nv + v)];
    const double kp = inertia * w * w, kv = 2 * setting.damping_ratio * inertia * w;
    const int a = servo[static_cast<size_t>(j)], b = damper[static_cast<size_t>(j)];
    m->actuator_gainprm[a * mjNGAIN] = kp;
    m->actuator_biasprm[a * mjNBIAS + 1] = -kp;
    // kv (qd_ref - qd): kv qd_ref from the actuator, -kv qd as joint damping.
    m->actuator_gainprm[b * mjNGAIN] = kv;
    m->actuator_biasprm[b * mjNBIAS + 2] = 0.0;
    m->dof_damping[v] += kv;
  }

  ReplayResult out;
  out.samples.resize(plan.samples.size());
  JointReference ref(plan.samples);
  JointVector q, qd, qdd;
  std::map<std::pair<int, int>, ReplayContact> contacts;
  const double t_end = plan.samples.back().t_s;
  const long steps = static_cast<long>(std::ceil(t_end / setting.timestep_s)) + 1;
  size_t next = 0;
  for (long i = 0; i <= steps && next < plan.samples.size(); ++i) {
    const double t = d->time;
    // Record every plan sample whose time has come: the joints now are the joints at t (the TCP follows from
    // them below; d's body poses are those the last step started from, a step earlier).
    while (next < plan.samples.size() && plan.samples[next].t_s <= t + 0.5 * setting.timestep_s) {
      ReplaySample& r = out.samples[next];
      const PlanSample& p = plan.samples[next];
      r.t_s = p.t_s;
      r.q_ref = p.q;
      for (int j = 0; j < n; ++j) r.q[j] = d->qpos[world.qpos_adr()[static_cast<size_t>(j)]];
      r.tcp_ref = p.T_base_tcp.translation();
      r.seam = p.seam;
      r.arc = p.arc;
      ++next;
    }
    ref.at(t, q, qd, qdd);
    for (int j = 0; j < n; ++j) {
      const int v = dof[static_cast<size_t>(j)];
      dref->qpos[world.qpos_adr()[static_cast<size_t>(j)]] = q[j];
      dref->qvel[v] = qd[j];
      dref->qacc[v] = qdd[j];
    }
    mj_inverse(ref_model.get(), dref.get());
    for (int j = 0; j < n; ++j) {
      const int v = dof[static_cast<size_t>(j)];
      d->ctrl[servo[static_cast<size_t>(j)]] = q[j];
      d->ctrl[damper[static_cast<size_t>(j)]] = qd[j];
      d->qfrc_applied[v] = dref->qfrc_inverse[v];
    }
    mj_step(m, d.get());
    // The contacts the step found are those of the state it started from, at t.
    for (int c = 0; c < d->ncon; ++c) {
      const mjContact& con = d->contact[c];
      if (con.dist > 0) continue;
      int g1 = con.geom1, g2 = con.geom2;
      const bool r1 = world.geom_label(g1) == Label::kRobot, r2 = world.geom_label(g2) == Label::kRobot;
      if (!r1 && !r2) continue;
      if (!r1) std::swap(g1, g2);
      ReplayContact& rc = contacts[{g1, g2}];
      if (rc.steps == 0) {
        rc.robot_geom = geom_name(m, g1);
        rc.other_geom = geom_name(m, g2);
        rc.other = world.geom_label(g2);
        rc.first_t_s = t;
      }
      rc.last_t_s = t;
      rc.max_depth_m = std::max(rc.max_depth_m, -con.dist);
      ++rc.steps;
    }
  }
  for (auto& [key, c] : contacts) out.contacts.push_back(c);

  // The TCP, and the clearance of every robot geom to the part's exact mesh, at every plan sample, on all
  // cores.
  const PartClearance clearance(world, part_mesh, T_base_part_true, setting.clearance_range_m);
  struct Worker {
    DataPtr data;
    PartClearance::Hint hint;  // runs of consecutive samples: the nearest point moves little between them
  };
  constexpr size_t kRun = 64;
  const size_t samples = out.samples.size();
  const int threads = setting.threads > 0
                          ? setting.threads
                          : static_cast<int>(std::min(4u, std::thread::hardware_concurrency()));
  parallel_for_with(
      (samples + kRun - 1) / kRun, threads,
      [&] {
        return Worker{DataPtr(mj_makeData(m)), {}};
      },
      [&](Worker& worker, size_t run) {
        for (size_t k = run * kRun; k < std::min((run + 1) * kRun, samples); ++k) {
          ReplaySample& r = out.samples[k];
          world.set_joints(worker.data.get(), r.q);
          const mjData* dk = worker.data.get();
          r.tcp = Vec3(dk->xpos[3 * tcp_body], dk->xpos[3 * tcp_body + 1], dk->xpos[3 * tcp_body + 2]);
          r.clearance_m = clearance.clearance(worker.data.get(), &r.clearance_geom, &worker.hint);
        }
      });

  // Figures.
  out.seams.resize(part.seams.size());
  for (size_t s = 0; s < part.seams.size(); ++s) out.seams[s].name = part.seams[s].name;
  out.min_clearance_m = std::numeric_limits<double>::infinity();
  double worst_seam_t = 0.0;
  int worst_seam = -1;
  double worst_track_t = 0.0;
  for (ReplaySample& r : out.samples) {
    out.max_tracking_rad = std::max(out.max_tracking_rad, (r.q - r.q_ref).cwiseAbs().maxCoeff());
    if (r.clearance_m < out.min_clearance_m) {
      out.min_clearance_m = r.clearance_m;
      out.min_clearance_geom = r.clearance_geom;
      out.min_clearance_t_s = r.t_s;
    }
    if (!r.arc || r.seam < 0) continue;
    const double track = (r.tcp - r.tcp_ref).norm();
    if (track > out.max_tcp_tracking_m) {
      out.max_tcp_tracking_m = track;
      worst_track_t = r.t_s;
    }
    // The nearest true seam: a pose turned by the part's symmetry welds the same seams in another order.
    r.seam_error_m = std::numeric_limits<double>::infinity();
    for (size_t s = 0; s < part.seams.size(); ++s)
      r.seam_error_m =
          std::min(r.seam_error_m, distance_to_seam(part, static_cast<int>(s), T_base_part_true, r.tcp));
    SeamFigure& f = out.seams[static_cast<size_t>(r.seam)];
    ++f.samples;
    f.rms_error_m += r.seam_error_m * r.seam_error_m;
    f.max_error_m = std::max(f.max_error_m, r.seam_error_m);
    if (r.seam_error_m > out.max_seam_error_m) {
      out.max_seam_error_m = r.seam_error_m;
      worst_seam_t = r.t_s;
      worst_seam = r.seam;
    }
  }
  for (SeamFigure& f : out.seams)
    if (f.samples > 0) f.rms_error_m = std::sqrt(f.rms_error_m / f.samples);

  // Verdict.
  for (const ReplayContact& c : out.contacts)
    out.failures.push_back("contact: " + c.robot_geom + " with " + c.other_geom + " (" + label_name(c.other) +
                           fmt(") from t = %.2f s, %.1f mm deep", c.first_t_s, 1e3 * c.max_depth_m));
  if (worst_seam >= 0 && out.max_seam_error_m > setting.max_seam_error_m)
    out.failures.push_back(
        "seam '" + part.seams[static_cast<size_t>(worst_seam)].name + "': the torch is " +
        fmt("%.2f mm from the true seam at t = %.2f s", 1e3 * out.max_seam_error_m, worst_seam_t));
  if (out.min_clearance_m < setting.min_clearance_m)
    out.failures.push_back(
        out.min_clearance_geom + (out.min_clearance_m < 0 ? " enters the part" : " touches the part") +
        fmt(" at t = %.2f s (clearance %.1f mm)", out.min_clearance_t_s, 1e3 * out.min_clearance_m));
  if (out.max_tcp_tracking_m > setting.max_tracking_m)
    out.failures.push_back(fmt("tracking: the TCP is %.2f mm off the plan while welding at t = %.2f s",
                               1e3 * out.max_tcp_tracking_m, worst_track_t));
  out.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  return out;
}

}  // namespace weldtwin
