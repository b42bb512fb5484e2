// asl_io.h: what both drivers read from a `vio export` folder (CSV fields, the IMU log) and
// the percentile of their timing lines; `fail` names the driver (DRIVER_NAME).
//
// Written for this project.

#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "utils/sensor_data.h"

#ifndef DRIVER_NAME
#error "define DRIVER_NAME before including asl_io.h"
#endif

namespace asl_io {

[[noreturn]] inline void fail(const std::string &what) {
  std::cerr << DRIVER_NAME ": " << what << std::endl;
  std::exit(2);
}

inline std::vector<std::string> split_csv(const std::string &line) {
  std::vector<std::string> out;
  std::stringstream ss(line);
  std::string field;
  while (std::getline(ss, field, ',')) {
    out.push_back(field);
  }
  return out;
}

inline int64_t parse_i64(const std::string &s, const std::string &file, size_t line) {
  try {
    size_t used = 0;
    long long v = std::stoll(s, &used);
    if (used != s.size()) {
      throw std::invalid_argument(s);
    }
    return v;
  } catch (const std::exception &) {
    fail(file + ":" + std::to_string(line) + ": `" + s + "` is not an integer");
  }
}

inline double parse_f64(const std::string &s, const std::string &file, size_t line) {
  try {
    size_t used = 0;
    double v = std::stod(s, &used);
    if (used != s.size()) {
      throw std::invalid_argument(s);
    }
    return v;
  } catch (const std::exception &) {
    fail(file + ":" + std::to_string(line) + ": `" + s + "` is not a number");
  }
}

inline std::vector<ov_core::ImuData> read_imu(const std::string &file) {
  std::ifstream in(file);
  if (!in) {
    fail(file + ": cannot open");
  }
  std::vector<ov_core::ImuData> out;
  std::string line;
  size_t n = 0;
  while (std::getline(in, line)) {
    n++;
    if (line.empty() || line[0] == '#') {
      continue;
    }
    auto f = split_csv(line);
    if (f.size() != 7) {
      fail(file + ":" + std::to_string(n) + ": expected 7 columns (t_ns, w xyz, a xyz)");
    }
    ov_core::ImuData d;
    d.timestamp = parse_i64(f[0], file, n) * 1e-9;
    d.wm << parse_f64(f[1], file, n), parse_f64(f[2], file, n), parse_f64(f[3], file, n);
    d.am << parse_f64(f[4], file, n), parse_f64(f[5], file, n), parse_f64(f[6], file, n);
    if (!out.empty() && d.timestamp <= out.back().timestamp) {
      fail(file + ":" + std::to_string(n) + ": timestamps not increasing");
    }
    out.push_back(d);
  }
  return out;
}

inline double percentile(std::vector<double> v, double p) {
  if (v.empty()) {
    return 0.0;
  }
  std::sort(v.begin(), v.end());
  size_t k = (size_t)std::min<double>(v.size() - 1, std::max(0.0, std::ceil(p * v.size()) - 1));
  return v[k];
}

}  // namespace asl_io
