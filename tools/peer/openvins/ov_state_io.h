// ov_state_io.h: what both drivers write of OpenVINS's newest state, as the harness's adapter
// contract asks (scenarios/src/spec/estimator_adapter.rs): the IMU's pose as a TUM row, and
// beside it the state with its covariance (`covariance` file: `t`, velocity, the two biases,
// the 15x15 covariance row by row over the harness's error state [dp, dtheta, dv, dba, dbg]).
//
// OpenVINS's IMU error state orders [dtheta, dp, dv, dbg, dba]; its orientation is the JPL
// quaternion of global-to-IMU with q = dq (x) q_hat, so R_GtoI = (I - [dtheta]x) R_hat_GtoI and
// R_ItoG = R_hat_ItoG (I + [dtheta]x): a right perturbation of the IMU-to-world rotation in the
// IMU frame, the harness's convention. Asking StateHelper for the marginal covariance of
// {p, q, v, ba, bg} gives the harness's order directly.
//
// Written for this project.

#pragma once

#include <cstdio>
#include <memory>
#include <ostream>
#include <vector>

#include <Eigen/Dense>

#include "state/State.h"
#include "state/StateHelper.h"
#include "types/IMU.h"
#include "utils/quat_ops.h"

namespace ov_state_io {

// The newest state's stamp on the IMU clock: the filter's time plus its camera-IMU offset.
inline double imu_stamp(const std::shared_ptr<ov_msckf::State> &state) {
  return state->_timestamp + state->_calib_dt_CAMtoIMU->value()(0);
}

// Writes the pose row (TUM: t p q_xyzw, the IMU in the world) and, when `cov` is given, the
// state-and-covariance row of the newest state.
inline void write_state(const std::shared_ptr<ov_msckf::State> &state, std::ostream &est, std::ostream *cov) {
  const auto &imu = state->_imu;
  Eigen::Matrix3d R_ItoG = ov_core::quat_2_Rot(imu->quat()).transpose();
  Eigen::Quaterniond q(R_ItoG);
  Eigen::Vector3d p = imu->pos();
  double t = imu_stamp(state);
  char row[256];
  std::snprintf(row, sizeof row, "%.9f %.9f %.9f %.9f %.9f %.9f %.9f %.9f\n", t, p.x(), p.y(), p.z(), q.x(), q.y(),
                q.z(), q.w());
  est << row;
  if (cov == nullptr) {
    return;
  }
  std::vector<std::shared_ptr<ov_type::Type>> order = {imu->p(), imu->q(), imu->v(), imu->ba(), imu->bg()};
  Eigen::MatrixXd P = ov_msckf::StateHelper::get_marginal_covariance(state, order);
  Eigen::MatrixXd S = 0.5 * (P + P.transpose());
  std::snprintf(row, sizeof row, "%.9f", t);
  *cov << row;
  Eigen::Vector3d v = imu->vel(), ba = imu->bias_a(), bg = imu->bias_g();
  for (const Eigen::Vector3d *x : {&v, &ba, &bg}) {
    for (int i = 0; i < 3; i++) {
      std::snprintf(row, sizeof row, " %.12e", (*x)(i));
      *cov << row;
    }
  }
  for (int r = 0; r < 15; r++) {
    for (int c = 0; c < 15; c++) {
      std::snprintf(row, sizeof row, " %.12e", S(r, c));
      *cov << row;
    }
  }
  *cov << "\n";
}

}  // namespace ov_state_io
