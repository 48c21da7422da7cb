// saulctl sim: the simulated robot, shown to the world as hardware on pseudo-terminals.
#include <fmt/core.h>

#include <chrono>
#include <fstream>

#include "commands.hpp"
#include "live.hpp"
#include "saulsim/pty_server.hpp"

namespace saulctl {
namespace {

using namespace std::chrono;

struct SimOptions {
  double speed = 1.0;
  std::string duration;
  std::string paths_file = "sim.paths";
  std::uint32_t seed = 1;
  bool quiet = false;
  bool no_imu = false;
};

int run_sim(const SimOptions& opt) {
  saul::sim::WorldConfig config;
  config.plant.seed = opt.seed;
  saul::sim::World world(config);
  if (opt.no_imu) (void)world.command("imu off");  // pulled before power-on: BALANCE latches FAULT and says why
  saul::sim::PtyServer server(world);
  const auto& p = server.paths();
  std::ofstream(opt.paths_file) << "can=" << p.can << "\nbalance=" << p.balance << "\nio=" << p.io << "\ncontrol="
                                << p.control << "\n";
  fmt::print("saulctl sim: the simulated SAUL-TEE is running ({})\n",
             opt.speed > 0 ? fmt::format("{}x real time", opt.speed) : std::string("as fast as possible"));
  fmt::print("  CAN bus (virtual CANable2, slcan)  {}   e.g. saulctl monitor --link slcan:{}\n", p.can, p.can);
  fmt::print("  BALANCE console                    {}\n", p.balance);
  fmt::print("  IO console                         {}\n", p.io);
  fmt::print("  simulator control (help, push, rc loss, button down, ...)  {}\n", p.control);
  fmt::print("  paths written to {}\n", opt.paths_file);
  std::fflush(stdout);

  const bool limited = !opt.duration.empty();
  const auto limit_us = limited ? static_cast<std::uint64_t>(parse_duration(opt.duration).count()) * 1000 : 0;
  const auto start = steady_clock::now();
  auto next_status = start + seconds(5);
  while (!g_interrupted) {
    if (limited && world.now_us() >= limit_us) break;
    if (opt.speed > 0) {
      // Step until simulated time catches up with speed x wall time, then wait for input or the next step.
      const double wall_us = static_cast<double>(duration_cast<microseconds>(steady_clock::now() - start).count());
      const auto target = static_cast<std::uint64_t>(wall_us * opt.speed);
      int steps = 0;
      while (world.now_us() < target && steps < 200) {
        world.step();
        if (++steps % 5 == 0) server.service();
      }
      server.service();
      if (world.now_us() >= target) server.wait_input(1);
    } else {
      for (int i = 0; i < 10; ++i) world.step();
      server.service();
    }
    if (!opt.quiet && steady_clock::now() >= next_status) {
      next_status += seconds(5);
      fmt::print("sim: {} | bus: {} frames out, {} in, {} dropped\n", world.status_line(), server.frames_to_host(),
                 server.frames_from_host(), server.dropped());
      std::fflush(stdout);
    }
  }
  fmt::print("sim: stopped at {}\n", world.status_line());
  return kOk;
}

}  // namespace

void add_sim_command(CLI::App& app, Runner& run) {
  auto [cmd, o] = add_verb<SimOptions>(
      app, run, "sim", "Run the simulated robot (both boards' firmware on a physics model)", run_sim);
  cmd->add_option("--speed", o->speed, "multiple of real time; 0 = as fast as possible")->capture_default_str();
  add_duration_option(cmd, o->duration, "stop after this much simulated time; default: until Ctrl-C");
  cmd->add_option("--paths-file", o->paths_file, "where to write the pty paths (can=, balance=, io=, control=)")
      ->capture_default_str();
  cmd->add_option("--seed", o->seed, "noise seed (runs with the same inputs and seed are identical)")->capture_default_str();
  cmd->add_flag("-q,--quiet", o->quiet, "no status line every 5 s");
  cmd->add_flag("--no-imu", o->no_imu,
                "start with the IMU pulled (BALANCE latches FAULT after 0.5 s and says why; 'imu on' plugs it back)");
  cmd->footer(
      "\nThe robot starts OFF on its bench stand, radio on (ARM switch up, speed cap 10 %). To balance it:\n"
      "  echo 'button down' > $CONTROL; sleep 3.2; echo 'button up' > $CONTROL   (3 s hold while upright)\n"
      "  saulctl mode balance --yes --link slcan:$CAN\n"
      "or on the BALANCE console: arm, then mode balance. Watch it: saulctl monitor --link slcan:$CAN\n"
      "\nA missing sensor: 'imu off' on the control console pulls the IMU (or start with --no-imu): BALANCE latches\n"
      "FAULT with the motors off, prints why on its console, sets watchdog_reset in 0x401 and keeps answering;\n"
      "'imu on' plugs it back (the FAULT stays until a disarm and a fresh arming).\n"
      "The plant has a QMI8658's noise and offsets, a stand that lets go slightly off balance and small floor\n"
      "disturbances (firmware/sim/README.md): it needs balancing, and different --seed values differ.\n"
      "\nExamples:\n  saulctl sim &\n  CAN=$(sed -n 's/^can=//p' sim.paths); CONTROL=$(sed -n 's/^control=//p' sim.paths)\n"
      "  python3 -c \"import can; b=can.Bus(interface='slcan', channel='$CAN', bitrate=500000); print(b.recv(1))\"\n");
}

}  // namespace saulctl
