// The names of a lightmap's output files. A lightmap is named by the job (an instance's `lightmap`, else its mesh's
// name), and the job's names are free text: "Chair/Seat" or "..\\wall" must not become a path, and two names must
// not become one file. Each lightmap gets a file stem that is a plain file name on every common file system, unique
// among the bake's lightmaps, and the same as the lightmap's name whenever that is already safe.
#pragma once

#include <map>
#include <set>
#include <string>
#include <string_view>

namespace kiln::scene {

// Longest stem in bytes: leaves room for the longest suffix ("_irradiance_denoised.exr", 24 bytes) and a "-N"
// disambiguation under the 255-byte name limit of ext4, NTFS and APFS.
inline constexpr size_t kMaxLightmapStemBytes = 200;

// `name` with every byte that is not safe in a file name on Linux, Windows or macOS replaced by '_': '/', '\\', ':',
// '*', '?', '"', '<', '>', '|', control characters and DEL; a leading '.' (a hidden file, "." and "..") and
// trailing dots and spaces (Windows drops them) also become '_'. Bytes from 0x80 up (UTF-8: names are valid UTF-8 in
// the protocol) are kept; a name longer than kMaxLightmapStemBytes is cut there without cutting a character. An
// empty name gives "lightmap".
std::string safe_file_stem(std::string_view name);

// Assigns each lightmap name its stem: safe_file_stem, then "-2", "-3", ... while the stem is taken by another name
// (compared without regard to ASCII case, as Windows and macOS compare file names). The first name asking for a stem
// gets it, so the result depends on the order of the calls (check_scene calls in instance order).
class LightmapFileNames {
 public:
  const std::string& stem(const std::string& name);
  // Every name whose stem differs from it, name → stem.
  std::map<std::string, std::string> renamed() const;

 private:
  std::map<std::string, std::string> stems_;  // name → stem
  std::set<std::string> taken_;               // stems, ASCII lower-cased
};

}  // namespace kiln::scene
