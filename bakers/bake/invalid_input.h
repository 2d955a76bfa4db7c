// The error every baker raises for a bad input: the field at fault and the problem, kept apart so that a caller (the
// daemon's translation layer) can place the field in its own message without parsing text.
#pragma once

#include <stdexcept>
#include <string>

namespace kiln::bake {

// `field` is the path of the offending member within the baker's input struct, in the struct's own names, with
// indices in brackets and map keys in brackets too: "model.alpha_x", "target_error", "meshes[2].indices",
// "textures[3]" (bytes that do not decode), "force_effects[sun_light]". It is empty when the whole input is at fault
// (a scene with nothing to bake). `problem` says what is wrong, for people: "must be in (0, 1], got -0.2".
// what() is "field: problem", or the problem alone for an empty field.
class InvalidInput : public std::invalid_argument {
 public:
  InvalidInput(std::string field, std::string problem)
      : std::invalid_argument(field.empty() ? problem : field + ": " + problem),
        field_(std::move(field)),
        problem_(std::move(problem)) {}

  const std::string& field() const { return field_; }
  const std::string& problem() const { return problem_; }

  // The same problem one level down, under `prefix` ("model" + "alpha_x" -> "model.alpha_x").
  InvalidInput under(const std::string& prefix) const {
    return InvalidInput(field_.empty() ? prefix : prefix + "." + field_, problem_);
  }

 private:
  std::string field_;
  std::string problem_;
};

}  // namespace kiln::bake
