// ov_feature_driver: runs OpenVINS (ov_msckf, no ROS) on a `vio export` folder's IMU log and
// feature tracks and writes its estimate as TUM, with the wall time each frame took.
//
//   ov_feature_driver CONFIG.yaml EXPORT_DIR ESTIMATE.tum TIMING.csv [COVARIANCE.txt]
//
// CONFIG.yaml is an OpenVINS estimator config (`%YAML:1.0`, its Kalibr files beside it, as
// `run.sh` lays them out). EXPORT_DIR holds `mav0/imu0/data.csv` and `features.csv`
// (`t_ns,cam_id,feature_id,u,v`, distorted pixels). The tracks are fed through OpenVINS's own
// simulated-feature tracker (TrackSIM) and the filter initializes itself as on images: static or
// dynamic initialization from the tracks and the IMU, never from the ground truth. Every frame is
// fed after the IMU samples up to 20 ms past it, single-threaded, so a run is deterministic.
//
// ESTIMATE.tum: one row per frame once initialized, `t x y z qx qy qz qw`, the IMU pose in the
// filter's world at the IMU-clock time of the frame (frame time + the estimated time offset).
// TIMING.csv: `t_ns,seconds` per frame fed (tracks → propagate → update, all of OpenVINS's work).
//
// COVARIANCE.txt (optional): per pose, the state and its 15x15 covariance in the harness's
// error-state order (ov_state_io.h), for `vio nees`.
//
// Written for this project; it links OpenVINS (GPL-3.0), built by `build.sh`.

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "core/VioManager.h"
#include "core/VioManagerOptions.h"
#include "init/InertialInitializer.h"
#include "state/Propagator.h"
#include "state/State.h"
#include "track/TrackSIM.h"
#include "types/IMU.h"
#include "types/Vec.h"
#include "update/UpdaterZeroVelocity.h"
#include "utils/opencv_yaml_parse.h"
#include "utils/print.h"
#include "utils/quat_ops.h"
#include "utils/sensor_data.h"

#define DRIVER_NAME "ov_feature_driver"
#include "asl_io.h"
#include "ov_state_io.h"

namespace {

using asl_io::fail;
using asl_io::parse_f64;
using asl_io::parse_i64;
using asl_io::percentile;
using asl_io::read_imu;
using asl_io::split_csv;

using Feats = std::vector<std::vector<std::pair<size_t, Eigen::VectorXf>>>;

struct Frame {
  int64_t t_ns = 0;
  std::vector<int> cam_ids;
  Feats feats;
};

// Frames of `features.csv`, feature ids renumbered densely in order of first sight from `first_id`
// on (OpenVINS keeps ids up to 4 × num_aruco for ArUco tags and compares ids as int).
std::vector<Frame> read_features(const std::string &file, size_t first_id, int cameras) {
  std::ifstream in(file);
  if (!in) {
    fail(file + ": cannot open");
  }
  std::vector<Frame> out;
  std::map<uint64_t, size_t> ids;
  std::string line;
  size_t n = 0;
  while (std::getline(in, line)) {
    n++;
    if (line.empty() || line.rfind("t_ns", 0) == 0) {
      continue;
    }
    auto f = split_csv(line);
    if (f.size() != 5) {
      fail(file + ":" + std::to_string(n) + ": expected 5 columns (t_ns,cam_id,feature_id,u,v)");
    }
    int64_t t_ns = parse_i64(f[0], file, n);
    int64_t cam = parse_i64(f[1], file, n);
    int64_t raw_id = parse_i64(f[2], file, n);
    if (cam < 0 || raw_id < 0) {
      fail(file + ":" + std::to_string(n) + ": negative camera or feature id");
    }
    if (cam >= cameras) {
      continue;  // a camera the config does not use
    }
    if (out.empty() || out.back().t_ns != t_ns) {
      if (!out.empty() && t_ns < out.back().t_ns) {
        fail(file + ":" + std::to_string(n) + ": timestamps not increasing");
      }
      out.push_back(Frame{t_ns, {}, {}});
    }
    Frame &fr = out.back();
    auto slot = std::find(fr.cam_ids.begin(), fr.cam_ids.end(), (int)cam);
    size_t k = slot - fr.cam_ids.begin();
    if (slot == fr.cam_ids.end()) {
      fr.cam_ids.push_back((int)cam);
      fr.feats.emplace_back();
    }
    auto [it, fresh] = ids.try_emplace((uint64_t)raw_id, first_id + ids.size());
    Eigen::VectorXf uv(2);
    uv << (float)parse_f64(f[3], file, n), (float)parse_f64(f[4], file, n);
    fr.feats[k].emplace_back(it->second, uv);
  }
  return out;
}

// VioManager fed feature tracks that initializes itself as the image path does
// (VioManager::feed_measurement_simulation requires an initialization from the ground truth).
class TrackFedVio : public ov_msckf::VioManager {
public:
  explicit TrackFedVio(ov_msckf::VioManagerOptions &options) : VioManager(options) {}

  void feed_tracks(double timestamp, const std::vector<int> &cam_ids, const Feats &feats) {
    auto sim = std::dynamic_pointer_cast<ov_core::TrackSIM>(trackFEATS);
    if (sim == nullptr) {
      sim = std::make_shared<ov_core::TrackSIM>(state->_cam_intrinsics_cameras, state->_options.max_aruco_features);
      trackFEATS = sim;
      initializer = std::make_shared<ov_init::InertialInitializer>(params.init_options, trackFEATS->get_feature_database());
      if (params.try_zupt) {
        updaterZUPT = std::make_shared<ov_msckf::UpdaterZeroVelocity>(
            params.zupt_options, params.imu_noises, trackFEATS->get_feature_database(), propagator, params.gravity_mag,
            params.zupt_max_velocity, params.zupt_noise_multiplier, params.zupt_max_disparity);
      }
    }
    sim->feed_measurement_simulation(timestamp, cam_ids, feats);

    ov_core::CameraData message;
    message.timestamp = timestamp;
    for (int cam : cam_ids) {
      auto &intrinsics = state->_cam_intrinsics_cameras.at(cam);
      message.sensor_ids.push_back(cam);
      message.images.push_back(cv::Mat::zeros(cv::Size(intrinsics->w(), intrinsics->h()), CV_8UC1));
      message.masks.push_back(cv::Mat::zeros(cv::Size(intrinsics->w(), intrinsics->h()), CV_8UC1));
    }
    if (is_initialized_vio && updaterZUPT != nullptr && (!params.zupt_only_at_beginning || !has_moved_since_zupt)) {
      if (state->_timestamp != timestamp) {
        did_zupt_update = updaterZUPT->try_update(state, timestamp);
      }
      if (did_zupt_update) {
        double td = state->_calib_dt_CAMtoIMU->value()(0);
        propagator->clean_old_imu_measurements(timestamp + td - 0.10);
        updaterZUPT->clean_old_imu_measurements(timestamp + td - 0.10);
        propagator->invalidate_cache();
        return;
      }
    }
    if (!is_initialized_vio) {
      is_initialized_vio = try_to_initialize(message);
      if (!is_initialized_vio) {
        return;
      }
    }
    do_feature_propagate_update(message);
  }

  // Whether the filter's newest state is the frame at `timestamp`.
  bool has_state_at(double timestamp) { return initialized() && state->_timestamp == timestamp; }

  // The filter's camera-IMU time offset (s), 0 before initialization.
  double time_offset() { return initialized() ? state->_calib_dt_CAMtoIMU->value()(0) : 0.0; }
};

}  // namespace

int main(int argc, char **argv) {
  if (argc != 5 && argc != 6) {
    std::cerr << "usage: ov_feature_driver CONFIG.yaml EXPORT_DIR ESTIMATE.tum TIMING.csv [COVARIANCE.txt]" << std::endl;
    return 2;
  }
  const std::string config = argv[1], dir = argv[2], est_path = argv[3], timing_path = argv[4];
  const std::string cov_path = argc == 6 ? argv[5] : "";

  auto parser = std::make_shared<ov_core::YamlParser>(config);
  std::string verbosity = "WARNING";
  parser->parse_config("verbosity", verbosity);
  ov_core::Printer::setPrintLevel(verbosity);
  ov_msckf::VioManagerOptions options;
  options.print_and_load(parser);
  options.use_multi_threading_subs = false;
  if (!parser->successful()) {
    fail(config + ": OpenVINS could not read every parameter it needs (see the messages above)");
  }

  const size_t first_id = 4 * (size_t)options.state_options.max_aruco_features + 1;
  auto imu = read_imu(dir + "/mav0/imu0/data.csv");
  auto frames = read_features(dir + "/features.csv", first_id, options.state_options.num_cameras);
  if (imu.empty() || frames.empty()) {
    fail(dir + ": no IMU samples or no feature frames");
  }

  TrackFedVio vio(options);
  std::ofstream est(est_path), timing(timing_path), cov;
  if (!cov_path.empty()) {
    cov.open(cov_path);
  }
  if (!est || !timing || (!cov_path.empty() && !cov)) {
    fail("cannot write " + est_path + ", " + timing_path + " or " + cov_path);
  }
  timing << "t_ns,seconds\n";
  std::vector<double> after_init;
  size_t next_imu = 0, estimates = 0;
  double init_time = -1.0;
  for (const auto &fr : frames) {
    double t = fr.t_ns * 1e-9;
    while (next_imu < imu.size() && imu[next_imu].timestamp <= t + 0.02) {
      vio.feed_measurement_imu(imu[next_imu++]);
    }
    auto start = std::chrono::steady_clock::now();
    vio.feed_tracks(t, fr.cam_ids, fr.feats);
    double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    timing << fr.t_ns << "," << seconds << "\n";
    if (vio.has_state_at(t)) {
      ov_state_io::write_state(vio.get_state(), est, cov_path.empty() ? nullptr : &cov);
      if (init_time < 0.0) {
        init_time = t;
      }
      after_init.push_back(seconds);
      estimates++;
    }
  }
  double mean = 0.0;
  for (double x : after_init) {
    mean += x / (double)after_init.size();
  }
  std::printf("ov_feature_driver: %zu frames, %zu IMU samples; initialized at %.3f s; %zu estimates; per frame "
              "after initialization: median %.3f ms, mean %.3f ms, p99 %.3f ms; final time offset %.4f ms\n",
              frames.size(), imu.size(), init_time - frames.front().t_ns * 1e-9, estimates,
              1e3 * percentile(after_init, 0.5), 1e3 * mean, 1e3 * percentile(after_init, 0.99),
              1e3 * vio.time_offset());
  return estimates > 0 ? 0 : 1;
}
