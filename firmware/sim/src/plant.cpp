#include "saulsim/plant.hpp"

#include <algorithm>
#include <cmath>

#include "saulproto/core/vesc.hpp"

namespace saul::sim {
namespace {
constexpr double kG = 9.80665;

// The IMU's figures, from QST's QMI8658C datasheet (Rev 0.6, Jan 2021, and Rev 0.8, Sep 2021, "Features" and
// "Description"): gyroscope noise density 15 mdps/sqrt(Hz), accelerometer noise density 200 ug/sqrt(Hz) (Rev A of
// June 2022 gives 150 ug/sqrt(Hz); the noisier figure is used). At the 1 kHz output rate the glue sets, with no
// low-pass filter, the noise fills the 500 Hz Nyquist band: sd = density x sqrt(500 Hz) = 0.34 deg/s and 4.5 mg per
// sample (the old sim used 0.02 deg/s and 1 mg). The offsets are an uncalibrated part's: the datasheet's
// specification table gives the gyroscope's zero-rate offset and the accelerometer's zero-g offset as a few deg/s
// and some tens of mg (quoted from memory, not re-read: the table was not at hand). The firmware does no
// calibration, so the sim draws each axis' offset per seed within +-1 deg/s and +-20 mg (PlantConfig), which moves
// the filtered pitch by up to about 1 deg x filter tau/s + 1.1 deg: the balance point the firmware's speed loop
// must find. Registers: 16 bits at +-8 g and +-512 deg/s (the glue's CTRL2/CTRL3).
double quantize(double v, double lsb) { return lsb > 0 ? std::round(v / lsb) * lsb : v; }

}  // namespace

double Vesc::step(double dt, double now_s) {
  if (!alive) {
    // A dead controller: the motor coasts.
    const double before = speed_mps_;
    speed_mps_ *= std::max(0.0, 1.0 - dt * 0.5);
    current_a_ = 0;
    return (speed_mps_ - before) / dt;
  }
  released_ = !commanded_ || now_s - last_command_s_ > config_->vesc_timeout_s;
  const double before = speed_mps_;
  if (released_) {
    speed_mps_ *= std::max(0.0, 1.0 - dt * 0.5);  // freewheeling, rolling resistance
  } else {
    const double target = static_cast<double>(target_erpm_) / config_->pole_pairs * config_->wheel_circumference_m / 60.0;
    double a = (target - speed_mps_) / config_->speed_loop_tau_s;
    a = std::clamp(a, -config_->max_accel_mps2, config_->max_accel_mps2);
    speed_mps_ += a * dt;
  }
  const double a = (speed_mps_ - before) / dt;
  current_a_ = released_ ? 0.0 : 1.5 + 4.0 * std::fabs(a) + 2.0 * std::fabs(speed_mps_);
  tacho += speed_mps_ / config_->wheel_circumference_m * config_->pole_pairs * 6.0 * dt;
  return a;
}

std::int32_t Vesc::erpm() const {
  return static_cast<std::int32_t>(std::lround(speed_mps_ * 60.0 / config_->wheel_circumference_m * config_->pole_pairs));
}

Plant::Plant(const PlantConfig& config)
    : config_(config), left_(vesc::kLeftId, config_), right_(vesc::kRightId, config_), rng_(config.seed) {
  battery_v_ = config_.battery_full_v;
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  for (auto& o : gyro_offset_) o = config_.gyro_offset_max_dps * unit(rng_);
  for (auto& o : accel_offset_) o = config_.accel_offset_max_g * unit(rng_);
  const double u = unit(rng_);  // the stand's angle: a side and a size within min..max
  const double size = config_.stand_min_deg + (config_.stand_max_deg - config_.stand_min_deg) * std::fabs(u);
  stand_pitch_ = std::copysign(size, u) * kDegToRad;
  pitch_ = stand_pitch_;
}

void Plant::release_stand() {
  if (!on_stand_) return;
  on_stand_ = false;
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  rate_ = config_.release_rate_max_dps * unit(rng_) * kDegToRad;
}

void Plant::upright() {
  if (on_stand_) return;
  tilt(stand_pitch_ / kDegToRad);  // the hands bring it back along a path the gyro sees, then it sits on the stand
  to_stand_ = true;
  if (tilt_left_s_ <= 0) on_stand_ = true;
}

void Plant::push(double dps) {
  on_stand_ = false;
  to_stand_ = false;
  tilt_left_s_ = 0;
  push_left_s_ = config_.push_s;
  push_alpha_ = config_.push_s > 0 ? dps * kDegToRad / config_.push_s : 0;
  if (config_.push_s <= 0) rate_ += dps * kDegToRad;
}

void Plant::tilt(double deg) {
  on_stand_ = false;
  to_stand_ = false;
  push_left_s_ = 0;
  tilt_from_ = pitch_;
  tilt_to_ = deg * kDegToRad;
  tilt_left_s_ = config_.tilt_s;
  if (config_.tilt_s <= 0) {
    pitch_ = tilt_to_;
    rate_ = 0;
  }
}

void Plant::step(double dt, double now_s) {
  const double al = left_.step(dt, now_s);
  const double ar = right_.step(dt, now_s);
  accel_ = (al + ar) / 2;
  distance_m_ += speed_mps() * dt;
  // The floor: an Ornstein-Uhlenbeck process (exact discretisation), sd floor_accel_sd, correlation floor_tau.
  if (config_.floor_tau_s > 0) {
    const double k = std::exp(-dt / config_.floor_tau_s);
    floor_ = floor_ * k + config_.floor_accel_sd_radps2 * std::sqrt(1.0 - k * k) * unit_(rng_);
  }
  const double before = rate_;
  if (on_stand_) {
    pitch_ = stand_pitch_;
    rate_ = 0;
  } else if (tilt_left_s_ > 0) {
    // The hand: smoothstep from tilt_from_ to tilt_to_, pitch and rate along the path (it overpowers the rest).
    tilt_left_s_ = std::max(0.0, tilt_left_s_ - dt);
    const double x = 1.0 - tilt_left_s_ / config_.tilt_s;
    pitch_ = tilt_from_ + (tilt_to_ - tilt_from_) * x * x * (3.0 - 2.0 * x);
    rate_ = (tilt_to_ - tilt_from_) * 6.0 * x * (1.0 - x) / config_.tilt_s;
    if (tilt_left_s_ <= 0 && to_stand_) on_stand_ = true;
  } else {
    double alpha = (kG * std::sin(pitch_) + accel_ * std::cos(pitch_)) / config_.pendulum_length_m + floor_;
    if (push_left_s_ > 0) {
      const double share = std::min(dt, push_left_s_) / dt;
      alpha += push_alpha_ * share;
      push_left_s_ -= dt;
    }
    rate_ += alpha * dt;
    pitch_ += rate_ * dt;
    const double rest = config_.rest_deg * kDegToRad;
    if (std::fabs(pitch_) > rest) {  // lying on its frame
      pitch_ = std::copysign(rest, pitch_);
      rate_ = 0;
    }
  }
  alpha_ = (rate_ - before) / dt;
  const double current = 0.4 + left_.current_a() + right_.current_a();
  used_ah_ += current * dt / 3600.0;
  const double soc = std::clamp(1.0 - used_ah_ / config_.battery_capacity_ah, 0.0, 1.0);
  const double open_circuit = 33.0 + (config_.battery_full_v - 33.0) * soc;
  battery_v_ = open_circuit - current * config_.battery_resistance_ohm;
}

fw::ImuSample Plant::imu_sample(fw::TimeUs t_us) {
  fw::ImuSample s;
  s.t_us = t_us;
  const double band = std::sqrt(config_.imu_noise_bandwidth_hz);
  const double an = config_.accel_noise_density_g * band;
  const double gn = config_.gyro_noise_density_dps * band;
  const auto accel = [&](double v, int axis) {
    return static_cast<float>(quantize(v + accel_offset_[static_cast<std::size_t>(axis)] + an * unit_(rng_), config_.accel_lsb_g));
  };
  const auto gyro = [&](double v, int axis) {
    return static_cast<float>(quantize(v + gyro_offset_[static_cast<std::size_t>(axis)] + gn * unit_(rng_), config_.gyro_lsb_dps));
  };
  // Specific force at the board: the base's acceleration and gravity, plus the board's own motion about the axle
  // (a nose-up angular acceleration moves it backward, -x; the rotation pulls it toward the axle, -z).
  const double a_g = accel_ / kG;
  const double h = config_.imu_height_m;
  s.ax = accel(std::sin(pitch_) + a_g * std::cos(pitch_) - h * alpha_ / kG, 0);
  s.ay = accel(0.0, 1);
  s.az = accel(std::cos(pitch_) - a_g * std::sin(pitch_) - h * rate_ * rate_ / kG, 2);
  // A nose-up pitch rate is a negative rate about +y (x forward, y left, z up, right-handed).
  s.gx = gyro(0.0, 0);
  s.gy = gyro(-rate_ / kDegToRad, 1);
  const double yaw_rate = (right_.speed_mps() - left_.speed_mps()) / config_.track_m / kDegToRad;
  s.gz = gyro(yaw_rate, 2);
  return s;
}

void Plant::on_can(const CanFrame& frame, double now_s) {
  const auto m = vesc::decode(frame);
  if (!m) return;
  if (const auto* rpm = std::get_if<vesc::SetRpm>(&m.value())) {
    for (Vesc* v : {&left_, &right_})
      if (v->alive && (rpm->controller_id == v->id() || rpm->controller_id == 0xFF)) v->command_erpm(rpm->erpm, now_s);
  }
}

std::vector<CanFrame> Plant::status_frames(double now_s) {
  std::vector<CanFrame> out;
  if (now_s >= next_status1_) {
    next_status1_ = now_s + 0.02;
    for (Vesc* v : {&left_, &right_}) {
      if (!v->alive) continue;
      const double duty = std::clamp(v->speed_mps() / 4.0, -0.95, 0.95);
      out.push_back(vesc::encode(vesc::Status1{v->id(), v->erpm(), static_cast<std::int16_t>(std::lround(v->current_a() * 10)),
                                               static_cast<std::int16_t>(std::lround(duty * 1000))}));
    }
  }
  if (now_s >= next_status5_) {
    next_status5_ = now_s + 0.1;
    for (Vesc* v : {&left_, &right_}) {
      if (!v->alive) continue;
      out.push_back(vesc::encode(vesc::Status5{v->id(), static_cast<std::int32_t>(v->tacho),
                                               static_cast<std::int16_t>(std::lround(battery_v_ * 10))}));
    }
  }
  return out;
}

double Plant::pitch_deg() const { return pitch_ / kDegToRad; }
double Plant::pitch_rate_dps() const { return rate_ / kDegToRad; }

}  // namespace saul::sim
