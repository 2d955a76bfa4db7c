// kilnd: the kiln baking daemon.
#include <signal.h>

#include <chrono>
#include <cstdio>
#include <iostream>
#include <thread>

#include "daemon/auth.h"
#include "daemon/config.h"
#include "daemon/log.h"
#include "daemon/open_files.h"
#include "daemon/server.h"
#include "daemon/service.h"

using namespace kiln::daemon;

int main(int argc, char** argv) {
  CommandLine cl;
  try {
    cl = parse_command_line(std::vector<std::string>(argv + 1, argv + argc));
    if (cl.help) {
      std::cout << usage();
      return 0;
    }
    validate(cl.config);
  } catch (const std::exception& e) {
    std::cerr << "kilnd: " << e.what() << "\n";
    return 2;
  }
  const Config& config = cl.config;

  // SIGINT and SIGTERM are taken by one thread with sigwait: blocked here, before any other thread exists, so that
  // every thread inherits the mask.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);
  // A client that vanishes mid-write must not kill the daemon.
  ::signal(SIGPIPE, SIG_IGN);

  try {
    const std::string limit_note = fit_open_file_limit(open_files_needed(config));
    if (!limit_note.empty()) log_line("start", limit_note);
    TokenSet tokens = config.token_file.empty() ? TokenSet{} : TokenSet::load(config.token_file);
    Service service(config, std::move(tokens));
    Server server(service);
    if (!config.listen.empty()) {
      const std::string host = config.listen.substr(0, config.listen.rfind(':'));
      std::printf("kilnd: listening on %s:%u\n", host.c_str(), static_cast<unsigned>(server.tcp_port()));
    }
    if (!config.socket.empty()) std::printf("kilnd: listening on unix:%s\n", config.socket.c_str());
    std::fflush(stdout);
    log_line("start", std::string(kServerVersion) + ", store " + config.store + ", " + std::to_string(config.workers) +
                          " worker(s)");

    std::thread waiter([&] {
      int sig = 0;
      sigwait(&signals, &sig);
      log_line("shutdown", std::string(sig == SIGINT ? "SIGINT" : "SIGTERM") + ": no new jobs; running jobs get " +
                               std::to_string(config.shutdown_grace_seconds) + " s to finish");
      service.shutdown(std::chrono::duration<double>(config.shutdown_grace_seconds));
      server.stop();
    });
    server.run(2);
    waiter.join();
    log_line("shutdown", "done");
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "kilnd: " << e.what() << "\n";
    return 1;
  }
}
