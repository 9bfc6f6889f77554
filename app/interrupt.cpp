#include "app/interrupt.hpp"

#include <unistd.h>
#include <csignal>

namespace mocap::engine {
namespace {

std::atomic<bool> g_interrupted{false};  // a signal handler can only reach process-wide state

extern "C" void on_signal(int signal) {
  if (g_interrupted.exchange(true)) _exit(128 + signal);
  constexpr char message[] =
      "\nmocap-clean: interrupted: finishing the clips in flight (again to abort)\n";
  [[maybe_unused]] auto n = write(STDERR_FILENO, message, sizeof(message) - 1);
}

}  // namespace

const std::atomic<bool>& install_interrupt_handler() {
  static const bool installed = [] {
    std::signal(SIGINT, on_signal);
    std::signal(SIGTERM, on_signal);
    return true;
  }();
  static_cast<void>(installed);
  return g_interrupted;
}

bool interrupted() {
  return g_interrupted.load();
}

}  // namespace mocap::engine
