// The wall-clock time of each stage of a bake, for its report: an RAII timer adds the time from its construction to
// its destruction to the stage's entry (a stage run once per lightmap, rasterization say, sums over them), so a stage
// that throws is still timed up to where it stopped.
#pragma once

#include <chrono>
#include <string>
#include <vector>

namespace kiln::lightmap {

struct StageTime {
  std::string name;
  double seconds = 0;
};

class StageTimer {
 public:
  StageTimer(std::vector<StageTime>& stages, std::string name)
      : stages_(stages), name_(std::move(name)), t0_(std::chrono::steady_clock::now()) {}
  ~StageTimer() {
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count();
    for (StageTime& st : stages_) {
      if (st.name == name_) {
        st.seconds += s;
        return;
      }
    }
    stages_.push_back({name_, s});
  }
  StageTimer(const StageTimer&) = delete;
  StageTimer& operator=(const StageTimer&) = delete;

 private:
  std::vector<StageTime>& stages_;
  std::string name_;
  std::chrono::steady_clock::time_point t0_;
};

}  // namespace kiln::lightmap
