#include "saulsim/plant.hpp"

#include <algorithm>
#include <cmath>

#include "saulproto/core/vesc.hpp"

namespace saul::sim {
namespace {
constexpr double kG = 9.80665;
}

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
}

void Plant::step(double dt, double now_s) {
  const double al = left_.step(dt, now_s);
  const double ar = right_.step(dt, now_s);
  accel_ = (al + ar) / 2;
  distance_m_ += speed_mps() * dt;
  if (on_stand_) {
    pitch_ = 0;
    rate_ = 0;
  } else {
    const double alpha = (kG * std::sin(pitch_) + accel_ * std::cos(pitch_)) / config_.pendulum_length_m;
    rate_ += alpha * dt;
    pitch_ += rate_ * dt;
    const double rest = config_.rest_deg * kDegToRad;
    if (std::fabs(pitch_) > rest) {  // lying on its frame
      pitch_ = std::copysign(rest, pitch_);
      rate_ = 0;
    }
  }
  const double current = 0.4 + left_.current_a() + right_.current_a();
  used_ah_ += current * dt / 3600.0;
  const double soc = std::clamp(1.0 - used_ah_ / config_.battery_capacity_ah, 0.0, 1.0);
  const double open_circuit = 33.0 + (config_.battery_full_v - 33.0) * soc;
  battery_v_ = open_circuit - current * config_.battery_resistance_ohm;
}

fw::ImuSample Plant::imu_sample(fw::TimeUs t_us) {
  fw::ImuSample s;
  s.t_us = t_us;
  const double a_g = accel_ / kG;
  s.ax = static_cast<float>(std::sin(pitch_) + a_g * std::cos(pitch_) + config_.accel_noise_g * unit_(rng_));
  s.ay = static_cast<float>(config_.accel_noise_g * unit_(rng_));
  s.az = static_cast<float>(std::cos(pitch_) - a_g * std::sin(pitch_) + config_.accel_noise_g * unit_(rng_));
  // A nose-up pitch rate is a negative rate about +y (x forward, y left, z up, right-handed).
  s.gx = static_cast<float>(config_.gyro_noise_dps * unit_(rng_));
  s.gy = static_cast<float>(-rate_ / kDegToRad + config_.gyro_bias_dps + config_.gyro_noise_dps * unit_(rng_));
  const double yaw_rate = (right_.speed_mps() - left_.speed_mps()) / config_.track_m / kDegToRad;
  s.gz = static_cast<float>(yaw_rate + config_.gyro_noise_dps * unit_(rng_));
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
