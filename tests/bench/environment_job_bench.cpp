// The whole environment bake, as kilnd runs it for `kiln bake env`: an encoded equirectangular image in, every
// output (KTX2, EXR faces, SH, DFG table, preview, report) out, at the job's defaults but the cube size (issue 21's
// case: 2048 × 1024 with a sun into a 256² cube at target 0.01). The daemon calls bake_environment with the same
// input on one worker; `report.json`'s stage seconds are the ones printed here.
//
//   kiln-sky --width 2048 --out sky.exr
//   environment_job_bench --image=sky.exr [--size=256] [--jobs=2] [--dfg_folder=DIR] [--table_out=FILE]
//
// Job j bakes with intensity j + 1 (distinct jobs, as the daemon's cache would not answer them) in one process, so
// the second and later jobs take the DFG table from the process's cache like a running kilnd. With --dfg_folder
// the tables are kept in files there too, as kilnd keeps them in its store's tables/: a second run's first job is
// a freshly started kilnd's first job after an earlier one computed the table. Per stage: wall
// seconds (the report's) and CPU seconds of the process (getrusage, every thread), taken at each stage's end through
// the bake's progress callback. The machine is shared: CPU seconds are what load inflates least, and a stage's
// CPU/wall says how many cores it kept busy.
//
// The load factor: before and after every job, a fixed arithmetic loop split over two TBB tasks measures how much
// of the two cores the process gets (f = wall / (CPU / 2); 1 on an idle machine, whose two cores run both tasks at
// once). The job's wall time divided by the mean f of the calibrations around it is its idle-machine estimate.
#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <exception>
#include <fstream>
#include <functional>
#include <iterator>
#include <string>
#include <utility>
#include <vector>

#include <tbb/parallel_for.h>

#include "bakers/envmap/dfg_cache.h"
#include "bakers/envmap/environment_bake.h"
#include "tests/bench/process_cpu.h"
#include "tests/bench/table_file.h"

namespace {

using kiln::bench::process_cpu_seconds;

double wall_seconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

// wall / (CPU / 2) of a fixed loop split over two tasks: how much slower than on two idle cores the process runs.
double load_factor() {
  std::atomic<double> sink{0.0};
  const double w0 = wall_seconds(), c0 = process_cpu_seconds();
  tbb::parallel_for(0, 2, [&](int task) {
    double x = 1.0 + task;
    for (int i = 0; i < 100'000'000; ++i) x = x * 0.999999 + 1e-6;  // a dependent chain: ~0.1-0.3 s of one core
    sink.store(x);
  });
  const double wall = wall_seconds() - w0, cpu = process_cpu_seconds() - c0;
  return cpu > 0.0 ? wall / (cpu / 2.0) : 1.0;
}

struct StageTimes {
  std::vector<std::string> names;
  std::vector<double> wall, cpu;
};

// One bake; the stages' wall seconds from the result, their CPU seconds from the progress callback.
StageTimes bake_once(const std::string& image, int size, double intensity, std::string* summary) {
  kiln::envmap::EnvironmentBakeInput in;
  in.image = image;
  in.size = size;
  in.decode.intensity = intensity;
  std::vector<double> cpu_at_end;
  kiln::bake::BakeControl control;
  control.progress = [&](const kiln::bake::BakeProgress&) { cpu_at_end.push_back(process_cpu_seconds()); };
  const double cpu0 = process_cpu_seconds();
  const kiln::envmap::EnvironmentBakeResult r = kiln::envmap::bake_environment(in, control);
  StageTimes t;
  double previous = cpu0;
  for (size_t s = 0; s < r.stage_seconds.size() && s < cpu_at_end.size(); ++s) {
    if (r.stage_seconds[s].first == "done") continue;
    t.names.push_back(r.stage_seconds[s].first);
    t.wall.push_back(r.stage_seconds[s].second);
    t.cpu.push_back(cpu_at_end[s] - previous);
    previous = cpu_at_end[s];
  }
  t.names.push_back("total");
  t.wall.push_back(r.seconds);
  t.cpu.push_back(process_cpu_seconds() - cpu0);
  // Every output but the report (which holds the timings), hashed: the same digest before and after a change
  // means the same bytes out (FNV-1a, 64 bits: a check of identity, not of integrity).
  uint64_t digest = 1469598103934665603ull;
  for (const kiln::bake::BakeOutput& o : r.outputs) {
    if (o.name == "report.json") continue;
    for (const std::string* part : {&o.name, &o.bytes})
      for (const char c : *part) digest = (digest ^ static_cast<unsigned char>(c)) * 1099511628211ull;
  }
  char hex[32];
  std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(digest));
  *summary = std::string("outputs ") + hex + "; DFG table " + r.dfg_table + "; N per level:";
  for (const auto& l : r.levels) {
    char buf[64];
    std::snprintf(buf, sizeof buf, " %d (%.4f)", l.samples, l.error_estimate);
    *summary += buf;
  }
  return t;
}

}  // namespace

int main(int argc, char** argv) {
  std::string image_path, table_out, command = argv[0];
  int size = 256, jobs = 2;
  bool usage = false;
  for (int i = 1; i < argc; ++i) {
    command += std::string(" ") + argv[i];
    if (std::strncmp(argv[i], "--image=", 8) == 0)
      image_path = argv[i] + 8;
    else if (std::strncmp(argv[i], "--size=", 7) == 0)
      size = std::atoi(argv[i] + 7);
    else if (std::strncmp(argv[i], "--jobs=", 7) == 0)
      jobs = std::atoi(argv[i] + 7);
    else if (std::strncmp(argv[i], "--table_out=", 12) == 0)
      table_out = argv[i] + 12;
    else if (std::strncmp(argv[i], "--dfg_folder=", 13) == 0)
      kiln::envmap::keep_dfg_tables_in(argv[i] + 13);
    else
      usage = true;
  }
  if (usage || image_path.empty() || size < 1 || jobs < 1) {
    std::fprintf(stderr, "usage: %s --image=FILE.exr [--size=256] [--jobs=2] [--dfg_folder=DIR] [--table_out=FILE]\n", argv[0]);
    return 1;
  }
  std::ifstream f(image_path, std::ios::binary);
  const std::string image((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  if (image.empty()) {
    std::fprintf(stderr, "cannot read %s\n", image_path.c_str());
    return 1;
  }
  std::string table;
  for (int j = 0; j < jobs; ++j) {
    std::string summary;
    const double load_before = load_factor();
    StageTimes t;
    try {
      t = bake_once(image, size, 1.0 + j, &summary);
    } catch (const std::exception& e) {
      // A size the bake refuses or an image it cannot read: its own message names the field.
      std::fprintf(stderr, "the bake of %s failed: %s\n", image_path.c_str(), e.what());
      return 1;
    }
    const double load = 0.5 * (load_before + load_factor());
    if (j == 0) {
      table += "| job |";
      for (const std::string& n : t.names) table += " " + n + " |";
      table += " load factor | total / load factor |\n|---|";
      for (size_t s = 0; s < t.names.size() + 2; ++s) table += "---|";
      table += "\n";
    }
    std::string row = "| " + std::to_string(j + 1) + ", wall (CPU) s |";
    for (size_t s = 0; s < t.names.size(); ++s) {
      char buf[64];
      std::snprintf(buf, sizeof buf, " %.3f (%.3f) |", t.wall[s], t.cpu[s]);
      row += buf;
    }
    char buf[64];
    std::snprintf(buf, sizeof buf, " %.2f | %.3f |", load, t.wall.back() / load);
    row += buf;
    std::printf("%s\n  %s\n", row.c_str(), summary.c_str());
    std::fflush(stdout);
    table += row + "\n";
  }
  table += "\nCommand: `" + command + "`\n";
  std::printf("\n%s", table.c_str());
  return kiln::bench::write_table_file(table, table_out);
}
