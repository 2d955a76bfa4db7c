#include "client/cli/job_file.h"

#include <google/protobuf/io/tokenizer.h>
#include <google/protobuf/text_format.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <iostream>
#include <iterator>
#include <sstream>
#include <vector>

#include "client/cli/args.h"
#include "proto/kiln.pb.h"

namespace kiln::cli {
namespace {

namespace pb = google::protobuf;

// A job spec travels in one control frame (4 MiB by default); anything larger would be refused by the server.
constexpr std::size_t kMaxJobFileBytes = std::size_t{4} << 20;

class FirstError : public pb::io::ErrorCollector {
 public:
  void AddError(int line, pb::io::ColumnNumber column, const std::string& message) override {
    if (!error) {
      error = message;
      this->line = line;
      this->column = column;
    }
  }
  std::optional<std::string> error;
  int line = 0, column = 0;  // 0-based, as protobuf gives them
};

bool is_word_char(char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; }

// Protobuf reports an unknown field or enum value where the parser stopped: after the name, often on the next
// line. People want the name itself: the last occurrence of the quoted name at or before that line, as a whole
// word. "LINE:COLUMN" 1-based.
std::string error_position(const std::string& text, const FirstError& e) {
  std::string at = std::to_string(e.line + 1) + ":" + std::to_string(e.column + 1);
  const std::string& m = *e.error;
  std::size_t q = std::string::npos;
  for (const char* lead : {"named \"", "value of \""}) {
    if (const auto p = m.find(lead); p != std::string::npos) q = p + std::strlen(lead);
  }
  if (q == std::string::npos) return at;
  const std::string name = m.substr(q, m.find('"', q) - q);
  if (name.empty()) return at;
  // The end of the reported line bounds the search.
  std::size_t end = 0;
  for (int l = 0; l <= e.line && end != std::string::npos; ++l) end = text.find('\n', end + (l ? 1 : 0));
  if (end == std::string::npos) end = text.size();
  std::optional<std::size_t> best;
  for (std::size_t p = text.find(name); p != std::string::npos && p + name.size() <= end; p = text.find(name, p + 1)) {
    const bool starts = p == 0 || !is_word_char(text[p - 1]);
    const bool ends = p + name.size() == text.size() || !is_word_char(text[p + name.size()]);
    if (starts && ends) best = p;
  }
  if (!best) return at;
  const std::size_t line_start = *best == 0 ? std::string::npos : text.rfind('\n', *best - 1);
  const std::size_t column = line_start == std::string::npos ? *best : *best - line_start - 1;
  const auto line = std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(*best), '\n');
  return std::to_string(line + 1) + ":" + std::to_string(column + 1);
}

std::string where(int line, int column) { return std::to_string(line + 1) + ":" + std::to_string(column + 1); }

}  // namespace

void parse_text_message(const std::string& text, const std::string& label, pb::Message& message) {
  pb::TextFormat::Parser parser;
  FirstError errors;
  parser.RecordErrorsTo(&errors);
  if (!parser.ParseFromString(text, &message)) {
    if (!errors.error) {
      throw UsageError(label + ": not a " + message.GetDescriptor()->full_name() + " in protobuf text format");
    }
    throw UsageError(label + ":" + error_position(text, errors) + ": " + *errors.error);
  }
}

void parse_job_text(const std::string& text, const std::string& label, v1::JobSpec& spec) {
  parse_text_message(text, label, spec);
  if (spec.job_case() == v1::JobSpec::JOB_NOT_SET) {
    throw UsageError(label +
                     ": no job in the file; it needs one, e.g. `material { ggx { alpha: 0.3 } }` "
                     "(see client/examples/)");
  }
}

std::string read_text_file(const std::string& path, const std::string& what, std::size_t max_bytes) {
  const std::string label = path == "-" ? "<stdin>" : path;
  std::ifstream file;
  std::istream* in = &std::cin;
  if (path != "-") {
    file.open(path, std::ios::binary);
    if (!file) throw UsageError("cannot read " + what + " " + path + ": " + std::strerror(errno));
    in = &file;
  }
  // Read one byte past the limit, so that a too-large file is refused without being read whole.
  std::string text;
  char buf[64 << 10];
  while (text.size() <= max_bytes && in->read(buf, sizeof buf).gcount() > 0) {
    text.append(buf, static_cast<std::size_t>(in->gcount()));
  }
  if (in->bad()) throw UsageError("cannot read " + what + " " + label + ": " + std::strerror(errno));
  if (text.size() > max_bytes) {
    throw UsageError(label + ": larger than " + std::to_string(max_bytes >> 20) + " MiB; a " + what +
                     " holds settings, and large inputs go in blobs");
  }
  return text;
}

void read_job_file(const std::string& path, v1::JobSpec& spec, std::string& text) {
  text = read_text_file(path, "job file", kMaxJobFileBytes);
  parse_job_text(text, path == "-" ? "<stdin>" : path, spec);
}

std::optional<std::string> locate_field(const std::string& text, const std::string& field_path) {
  pb::TextFormat::Parser parser;
  FirstError errors;  // the text parsed before; this keeps a parse failure quiet all the same
  parser.RecordErrorsTo(&errors);
  pb::TextFormat::ParseInfoTree tree;
  parser.WriteLocationsTo(&tree);
  v1::JobSpec spec;
  if (!parser.ParseFromString(text, &spec)) return std::nullopt;

  // The path is from the Submit body: "job" is the spec itself.
  std::vector<std::string> parts;
  std::stringstream ss(field_path);
  for (std::string item; std::getline(ss, item, '.');) parts.push_back(item);
  if (parts.empty() || parts[0] != "job") return std::nullopt;

  const pb::Descriptor* descriptor = v1::JobSpec::descriptor();
  const pb::TextFormat::ParseInfoTree* node = &tree;
  std::optional<std::string> found;
  for (std::size_t i = 1; i < parts.size() && node && descriptor; ++i) {
    std::string name = parts[i];
    int index = -1;  // -1: a singular field
    if (const auto bracket = name.find('['); bracket != std::string::npos) {
      const std::string key = name.substr(bracket + 1, name.size() - bracket - 2);
      name = name.substr(0, bracket);
      // A repeated field's [i]; a map's [key] points at its first entry (the map keeps no order to match).
      index = !key.empty() && key.find_first_not_of("0123456789") == std::string::npos && key.size() < 9
                  ? std::stoi(key)
                  : 0;
    }
    const pb::FieldDescriptor* field = descriptor->FindFieldByName(name);
    if (!field) break;
    // An index on a singular field ("job.material[0]") names nothing in the text (and protobuf's GetLocation
    // aborts the process on one): the enclosing field is as near as the path gets.
    if (!field->is_repeated() && index >= 0) break;
    if (field->is_repeated() && index < 0) index = 0;
    const auto location = node->GetLocation(field, index);
    if (location.line < 0) break;
    found = where(location.line, location.column);
    if (field->cpp_type() != pb::FieldDescriptor::CPPTYPE_MESSAGE) break;
    node = node->GetTreeForNested(field, index);
    descriptor = field->message_type();
  }
  return found;
}

}  // namespace kiln::cli
