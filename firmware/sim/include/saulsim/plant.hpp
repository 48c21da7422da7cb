// The physical robot for the simulator: the body's pitch on two driven wheel pairs, two VESCs in RPM mode, the
// battery, and the QMI8658's samples. Host-side code (not firmware): plain C++ with the standard library.
//
// Model (small, honest, good enough to close the loop):
//  - body: an inverted pendulum of effective length l on the wheel axle. pitch > 0 = nose up (the top leans back).
//    pitch'' = (g sin(pitch) + a cos(pitch)) / l, with a the forward acceleration of the wheels. Pushing it
//    (fault injection) adds to the pitch rate. Beyond +-kRestDeg the body rests on its frame (no further fall).
//  - each VESC holds its commanded ERPM with a first-order speed loop (time constant tau, acceleration limited by
//    the motor), releases (freewheels, slowly coasting down) when no SET_RPM came for its timeout (1 s default),
//    and reports STATUS at 50 Hz and STATUS_5 at 10 Hz when alive.
//  - battery: open-circuit voltage falling slowly with charge used, minus internal resistance x current.
//  - IMU: accelerometer (g) and gyro (deg/s) in the body frame (x forward, y left, z up) from the state, with
//    white noise and a constant gyro bias, from a seeded generator (deterministic runs).
// A bench stand holds the body upright (pitch 0) until released, like a tethered robot at the bench.
#pragma once

#include <cstdint>
#include <optional>
#include <random>
#include <vector>

#include "saulfw/hal.hpp"
#include "saulproto/core/can_frame.hpp"

namespace saul::sim {

struct PlantConfig {
  double pendulum_length_m = 0.35;
  double wheel_circumference_m = 0.628;  ///< matches the firmware's default 200 mm wheels
  int pole_pairs = 7;
  double speed_loop_tau_s = 0.05;
  double max_accel_mps2 = 6.0;
  double track_m = 0.46;
  double rest_deg = 30.0;                ///< the frame touches the ground here
  double vesc_timeout_s = 1.0;           ///< APPCONF_TIMEOUT_MSEC default
  double battery_full_v = 41.5;
  double battery_capacity_ah = 10.0;
  double battery_resistance_ohm = 0.12;
  double accel_noise_g = 0.005;
  double gyro_noise_dps = 0.05;
  double gyro_bias_dps = 0.1;
  std::uint32_t seed = 1;
};

class Vesc {
 public:
  Vesc(std::uint8_t id, const PlantConfig& c) : id_(id), config_(&c) {}
  void command_erpm(std::int32_t erpm, double now_s) {
    target_erpm_ = erpm;
    last_command_s_ = now_s;
    commanded_ = true;
  }
  /// Advances the speed loop; returns the wheel's acceleration in m/s^2.
  double step(double dt, double now_s);
  [[nodiscard]] double speed_mps() const { return speed_mps_; }
  [[nodiscard]] std::int32_t erpm() const;
  [[nodiscard]] double current_a() const { return current_a_; }
  [[nodiscard]] std::uint8_t id() const { return id_; }
  [[nodiscard]] bool released() const { return released_; }
  bool alive = true;     ///< false: a dead controller (fault injection): no status, ignores commands
  double tacho = 0;      ///< electrical revolutions x 6, as the VESC counts

 private:
  std::uint8_t id_;
  const PlantConfig* config_;
  std::int32_t target_erpm_ = 0;
  double last_command_s_ = -1e9;
  bool commanded_ = false;
  bool released_ = true;
  double speed_mps_ = 0;
  double current_a_ = 0;
};

class Plant {
 public:
  explicit Plant(const PlantConfig& config = {});

  /// Advances by dt seconds (now_s is the time after the step).
  void step(double dt, double now_s);
  /// One IMU sample of the current state, stamped t_us.
  fw::ImuSample imu_sample(fw::TimeUs t_us);

  /// A CAN frame from BALANCE: SET_RPM to a VESC is taken; everything else ignored.
  void on_can(const CanFrame& frame, double now_s);
  /// Status frames due at now_s (STATUS 50 Hz, STATUS_5 10 Hz from each live VESC).
  std::vector<CanFrame> status_frames(double now_s);

  // state
  [[nodiscard]] double pitch_deg() const;
  [[nodiscard]] double pitch_rate_dps() const;
  [[nodiscard]] double speed_mps() const { return (left_.speed_mps() + right_.speed_mps()) / 2; }
  [[nodiscard]] double battery_v() const { return battery_v_; }
  [[nodiscard]] bool on_stand() const { return on_stand_; }
  [[nodiscard]] double distance_m() const { return distance_m_; }
  Vesc& left() { return left_; }
  Vesc& right() { return right_; }

  // the bench
  void release_stand() { on_stand_ = false; }
  /// Puts the robot back upright on its stand (someone lifts it).
  void upright() {
    on_stand_ = true;
    pitch_ = 0;
    rate_ = 0;
  }
  /// A push: adds to the pitch rate (deg/s), also when on the stand (which then lets go).
  void push(double dps) {
    on_stand_ = false;
    rate_ += dps * kDegToRad;
  }
  void set_pitch(double deg) {
    on_stand_ = false;
    pitch_ = deg * kDegToRad;
    rate_ = 0;
  }

  static constexpr double kDegToRad = 0.017453292519943295;

 private:
  PlantConfig config_;
  Vesc left_;
  Vesc right_;
  double pitch_ = 0;  // rad, + nose up
  double rate_ = 0;   // rad/s
  double accel_ = 0;  // forward acceleration of the wheels, m/s^2
  double distance_m_ = 0;
  double used_ah_ = 0;
  double battery_v_ = 41.5;
  bool on_stand_ = true;
  double next_status1_ = 0;
  double next_status5_ = 0;
  std::mt19937 rng_;
  std::normal_distribution<double> unit_{0.0, 1.0};
};

}  // namespace saul::sim
