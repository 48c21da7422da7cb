// The physical robot for the simulator: the body's pitch on two driven wheel pairs, two VESCs in RPM mode, the
// battery, and the QMI8658's samples. Host-side code (not firmware): plain C++ with the standard library.
//
// Model (small, honest, good enough to close the loop):
//  - body: an inverted pendulum of effective length l on the wheel axle. pitch > 0 = nose up (the top leans back).
//    pitch'' = (g sin(pitch) + a cos(pitch)) / l + d, with a the forward acceleration of the wheels and d the
//    disturbances below. Beyond +-rest_deg the body rests on its frame (no further fall).
//  - disturbances, as a bench has them (all seeded): the floor's small bumps as a band-limited random angular
//    acceleration; a push (fault injection) as a short shove, an angular impulse spread over push_s; a tilt as a
//    hand moving the body to an angle along a smooth path, then letting go. The gyro sees every one as a rate.
//  - each VESC holds its commanded ERPM with a first-order speed loop (time constant tau, acceleration limited by
//    the motor), releases (freewheels, slowly coasting down) when no SET_RPM came for its timeout (1 s default),
//    and reports STATUS at 50 Hz and STATUS_5 at 10 Hz when alive.
//  - battery: open-circuit voltage falling slowly with charge used, minus internal resistance x current.
//  - IMU: accelerometer (g) and gyro (deg/s) in the body frame (x forward, y left, z up) at the board's height
//    above the axle (so the body's own angular acceleration reaches the accelerometer), with the QMI8658's white
//    noise, a constant per-seed offset on every axis and the register's resolution (plant.cpp cites the
//    datasheet). The World can pull the IMU (no samples at all).
// A bench stand holds the body still, slightly off balance (a per-seed angle within +-stand_max_deg), until
// released; it lets go with a small random rate, like a technician's hands.
#pragma once

#include <array>
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
  // IMU (figures and their source: plant.cpp)
  double gyro_noise_density_dps = 0.015;   ///< deg/s per sqrt(Hz)
  double accel_noise_density_g = 200e-6;   ///< g per sqrt(Hz)
  double imu_noise_bandwidth_hz = 500.0;   ///< 1 kHz output rate, no low-pass filter: the Nyquist band
  double gyro_offset_max_dps = 1.0;        ///< each axis' zero-rate offset: uniform in +- this, per seed
  double accel_offset_max_g = 0.02;        ///< each axis' zero-g offset: uniform in +- this, per seed
  double accel_lsb_g = 1.0 / 4096;         ///< +-8 g range (the glue's CTRL2)
  double gyro_lsb_dps = 1.0 / 64;          ///< +-512 dps range (the glue's CTRL3)
  double imu_height_m = 0.0;               ///< the board above the wheel axle (unknown: see firmware/sim/README.md)
  // the bench
  double stand_min_deg = 0.2;              ///< the stand holds the body at +-(min..max) degrees, per seed
  double stand_max_deg = 1.0;
  double release_rate_max_dps = 2.0;       ///< the rate it lets go with: uniform in +- this
  double floor_accel_sd_radps2 = 0.15;     ///< the floor's random angular acceleration (sd) ...
  double floor_tau_s = 0.05;               ///< ... and its correlation time
  double push_s = 0.02;                    ///< a push's duration
  double tilt_s = 0.25;                    ///< how long the hand takes to tilt the body
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
  /// The IMU's offsets drawn for this seed (gyro y in deg/s, accelerometer x in g): for tests and reports.
  [[nodiscard]] double gyro_offset_y_dps() const { return gyro_offset_[1]; }
  [[nodiscard]] double accel_offset_x_g() const { return accel_offset_[0]; }

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
  /// The stand lets go: the body starts from the stand's angle with a small random rate.
  void release_stand();
  /// Puts the robot back on its stand: the hands move it to the stand's angle over tilt_s (the gyro sees it), then
  /// the stand holds it. No-op when already on the stand.
  void upright();
  /// A shove: over push_s, an angular impulse that changes the pitch rate by dps deg/s (+ = nose up); also when
  /// on the stand (which then lets go).
  void push(double dps);
  /// A hand moves the body from where it is to deg degrees along a smooth path over tilt_s, then lets go (at
  /// rest). Lifts it off the stand.
  void tilt(double deg);
  [[nodiscard]] double stand_deg() const { return stand_pitch_ / kDegToRad; }

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
  double stand_pitch_ = 0;    // rad
  double floor_ = 0;          // the floor's angular acceleration now, rad/s^2
  double push_left_s_ = 0;    // a shove in progress: its angular acceleration and time left
  double push_alpha_ = 0;
  double tilt_left_s_ = 0;    // the hand in progress: from, to, time left
  double tilt_from_ = 0;
  double tilt_to_ = 0;
  bool to_stand_ = false;     // the hand is bringing it back to the stand
  double alpha_ = 0;          // the body's angular acceleration in the last step, rad/s^2
  std::array<double, 3> gyro_offset_{};
  std::array<double, 3> accel_offset_{};
  double next_status1_ = 0;
  double next_status5_ = 0;
  std::mt19937 rng_;
  std::normal_distribution<double> unit_{0.0, 1.0};
};

}  // namespace saul::sim
