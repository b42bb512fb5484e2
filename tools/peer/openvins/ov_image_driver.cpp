// ov_image_driver: runs OpenVINS (ov_msckf, no ROS) with its own KLT front end on a `vio export`
// folder's rendered images and IMU log, and writes its estimate as TUM, with the wall time each
// frame took — OpenVINS's whole pipeline on the frames our front end tracks.
//
//   ov_image_driver CONFIG.yaml EXPORT_DIR ESTIMATE.tum TIMING.csv [COVARIANCE.txt]
//
// CONFIG.yaml is an OpenVINS estimator config (`%YAML:1.0`, its Kalibr files beside it, as
// `run_adapter.sh` lays them out; its front-end keys use_klt, num_pts, fast_threshold, grid_x/y,
// min_px_dist, knn_ratio, histogram_method are OpenVINS's EuRoC values). EXPORT_DIR holds
// `mav0/imu0/data.csv` and `mav0/cam<i>/data.csv` with the PNGs under `mav0/cam<i>/data/`. Each
// capture (every camera's image of one stamp) is fed after the IMU samples up to 20 ms past it,
// single-threaded, as VioManager::feed_measurement_camera; dynamic initialization's solver is
// bounded by iterations (init_dyn_mle_max_time = 1000 s in the config instead of OpenVINS's
// 0.05 s of wall time, which a loaded 2-core machine misses), so a run is deterministic.
//
// ESTIMATE.tum: one row per capture once initialized, the IMU pose in the filter's world at the
// IMU-clock time of the capture (its stamp + the estimated time offset). TIMING.csv: `t_ns,seconds`
// per capture fed (track → propagate → update).
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
#include <opencv2/imgcodecs.hpp>

#include "core/VioManager.h"
#include "core/VioManagerOptions.h"
#include "state/State.h"
#include "types/IMU.h"
#include "types/Vec.h"
#include "utils/opencv_yaml_parse.h"
#include "utils/print.h"
#include "utils/quat_ops.h"
#include "utils/sensor_data.h"

#define DRIVER_NAME "ov_image_driver"
#include "asl_io.h"
#include "ov_state_io.h"

namespace {

using asl_io::fail;
using asl_io::parse_f64;
using asl_io::parse_i64;
using asl_io::percentile;
using asl_io::read_imu;
using asl_io::split_csv;

// One camera's images: `(t_ns, png path)` from its `data.csv`, in order.
std::vector<std::pair<int64_t, std::string>> read_images(const std::string &cam_dir) {
  const std::string file = cam_dir + "/data.csv";
  std::ifstream in(file);
  if (!in) {
    fail(file + ": cannot open");
  }
  std::vector<std::pair<int64_t, std::string>> out;
  std::string line;
  size_t n = 0;
  while (std::getline(in, line)) {
    n++;
    if (line.empty() || line[0] == '#') {
      continue;
    }
    auto f = split_csv(line);
    if (f.size() != 2) {
      fail(file + ":" + std::to_string(n) + ": expected 2 columns (t_ns, file name)");
    }
    int64_t t = parse_i64(f[0], file, n);
    if (!out.empty() && t <= out.back().first) {
      fail(file + ":" + std::to_string(n) + ": timestamps not increasing");
    }
    std::string name = f[1];
    while (!name.empty() && (name.back() == '\r' || name.back() == ' ')) {
      name.pop_back();
    }
    out.emplace_back(t, cam_dir + "/data/" + name);
  }
  return out;
}

}  // namespace

int main(int argc, char **argv) {
  if (argc != 5 && argc != 6) {
    std::cerr << "usage: ov_image_driver CONFIG.yaml EXPORT_DIR ESTIMATE.tum TIMING.csv [COVARIANCE.txt]" << std::endl;
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
  const int cameras = options.state_options.num_cameras;
  auto imu = read_imu(dir + "/mav0/imu0/data.csv");
  std::vector<std::vector<std::pair<int64_t, std::string>>> images;
  for (int c = 0; c < cameras; c++) {
    images.push_back(read_images(dir + "/mav0/cam" + std::to_string(c)));
  }
  if (imu.empty() || images[0].empty()) {
    fail(dir + ": no IMU samples or no images (export a rendered scenario)");
  }
  for (int c = 1; c < cameras; c++) {
    if (images[c].size() != images[0].size()) {
      fail(dir + ": cam" + std::to_string(c) + " has " + std::to_string(images[c].size()) + " images, cam0 " +
           std::to_string(images[0].size()) + ": the driver feeds synchronized captures");
    }
  }

  ov_msckf::VioManager vio(options);
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
  for (size_t k = 0; k < images[0].size(); k++) {
    const int64_t t_ns = images[0][k].first;
    const double t = t_ns * 1e-9;
    ov_core::CameraData message;
    message.timestamp = t;
    for (int c = 0; c < cameras; c++) {
      if (images[c][k].first != t_ns) {
        fail(dir + ": cam" + std::to_string(c) + " image " + std::to_string(k) + " is not stamped as cam0's");
      }
      cv::Mat img = cv::imread(images[c][k].second, cv::IMREAD_GRAYSCALE);
      if (img.empty()) {
        fail(images[c][k].second + ": cannot read the image");
      }
      message.sensor_ids.push_back(c);
      message.masks.push_back(cv::Mat::zeros(img.size(), CV_8UC1));
      message.images.push_back(img);
    }
    while (next_imu < imu.size() && imu[next_imu].timestamp <= t + 0.02) {
      vio.feed_measurement_imu(imu[next_imu++]);
    }
    auto start = std::chrono::steady_clock::now();
    vio.feed_measurement_camera(message);
    double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    timing << t_ns << "," << seconds << "\n";
    auto state = vio.get_state();
    if (vio.initialized() && state->_timestamp == t) {
      ov_state_io::write_state(state, est, cov_path.empty() ? nullptr : &cov);
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
  double td = vio.initialized() ? vio.get_state()->_calib_dt_CAMtoIMU->value()(0) : 0.0;
  std::printf("ov_image_driver: %zu captures, %zu IMU samples; initialized at %.3f s; %zu estimates; per capture "
              "after initialization: median %.3f ms, mean %.3f ms, p99 %.3f ms; final time offset %.4f ms\n",
              images[0].size(), imu.size(), init_time - images[0].front().first * 1e-9, estimates,
              1e3 * percentile(after_init, 0.5), 1e3 * mean, 1e3 * percentile(after_init, 0.99), 1e3 * td);
  return estimates > 0 ? 0 : 1;
}
