#include "bakers/volume/vdb_structure.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cctype>
#include <cmath>
#include <cstring>
#include <limits>
#include <sstream>
#include <string_view>

#include <openvdb/io/Compression.h>

#include "bakers/bake/invalid_input.h"

namespace kiln::volume {

namespace {

using bake::InvalidInput;

// OpenVDB's magic number, the first 8 bytes of every file ("VDB " little-endian).
constexpr int64_t kMagic = 0x56444220;
// Format versions: 222 stores compression per grid and a metadata byte per node (what this walk follows; older
// files lay nodes out differently), 224 is what OpenVDB 4 to 10 write.
constexpr uint32_t kFirstVersion = 222;
constexpr uint32_t kLastVersion = 224;
// Compression flags (io/Compression.h).
constexpr uint32_t kZip = 0x1;
constexpr uint32_t kActiveMask = 0x2;
constexpr uint32_t kBlosc = 0x4;
// Per-node metadata byte values (io/Compression.h): 0 to 6, NO_MASK_OR_INACTIVE_VALS to NO_MASK_AND_ALL_VALS.
constexpr uint8_t kNoMaskAndAllVals = 6;
constexpr size_t kBloscHeader = 16;
// Bound on root tiles' and children's origins: boxes OpenVDB and read_vdb compute from them (a node's last voxel, a
// grid's extent from its lowest to its highest voxel) then stay inside 32 bits.
constexpr int64_t kCoordBound = int64_t{1} << 29;
constexpr int64_t kUpperDim = 4096;  // voxels spanned by an upper node of the 5-4-3 tree

// A value type kiln lets OpenVDB read: its tree type name, bytes, and bytes as a half float (0: not a real type,
// so never stored as half).
struct ValueKind {
  std::string_view tree;
  int size;
  int half_size;
};
constexpr std::array<ValueKind, 7> kKinds{{{"Tree_float_5_4_3", 4, 2},
                                           {"Tree_double_5_4_3", 8, 2},
                                           {"Tree_int32_5_4_3", 4, 0},
                                           {"Tree_int64_5_4_3", 8, 0},
                                           {"Tree_vec3s_5_4_3", 12, 6},
                                           {"Tree_vec3d_5_4_3", 24, 6},
                                           {"Tree_vec3i_5_4_3", 12, 0}}};

// Metadata types OpenVDB 10 registers with a fixed size (openvdb.cc, points.cc): TypedMetadata reads sizeof(T)
// bytes whatever the size field says, so the field must say exactly that.
struct FixedMeta {
  std::string_view type;
  uint32_t size;
};
constexpr std::array<FixedMeta, 20> kFixedMeta{
    {{"bool", 1},    {"double", 8},  {"float", 4},   {"int32", 4},       {"int64", 8},
     {"vec2i", 8},   {"vec2s", 8},   {"vec2d", 16},  {"vec3i", 12},      {"vec3s", 12},
     {"vec3d", 24},  {"vec4i", 16},  {"vec4s", 16},  {"vec4d", 32},      {"mat4s", 64},
     {"mat4d", 128}, {"ptidx32", 4}, {"ptidx64", 8}, {"ptdataidx32", 4}, {"ptdataidx64", 8}}};

// Map types OpenVDB 10 registers and the doubles each reads (math/Maps.h); NonlinearFrustumMap is walked apart.
struct MapKind {
  std::string_view type;
  int doubles;
};
constexpr std::array<MapKind, 7> kMaps{{{"AffineMap", 16},
                                        {"UnitaryMap", 16},
                                        {"ScaleMap", 15},
                                        {"UniformScaleMap", 15},
                                        {"TranslationMap", 3},
                                        {"ScaleTranslateMap", 18},
                                        {"UniformScaleTranslateMap", 18}}};
constexpr std::string_view kFrustum = "NonlinearFrustumMap";

// What OpenVDB allocates, at most, per node of a tree of `size`-byte values: a child pointer and a value per table
// entry, the masks, and the temporary array readTopology reads the entries' values into.
int64_t upper_node_bytes(int size) { return 32768 * (8 + 2 * int64_t{size}) + 2 * 4096; }
int64_t lower_node_bytes(int size) { return 4096 * (8 + 2 * int64_t{size}) + 2 * 512; }
int64_t leaf_bytes(int size) { return 512 * int64_t{size} + 256; }
int64_t root_entry_bytes(int size) { return 96 + size; }

std::string ordinal(size_t i) {
  const size_t n = i + 1;
  const char* suffix = (n % 100 >= 11 && n % 100 <= 13) ? "th"
                       : n % 10 == 1                    ? "st"
                       : n % 10 == 2                    ? "nd"
                       : n % 10 == 3                    ? "rd"
                                                        : "th";
  return std::to_string(n) + suffix;
}

std::string printable(std::string_view s) {
  std::string out;
  for (char c : s.substr(0, 64)) out += (c >= 32 && c < 127) ? c : '?';
  if (s.size() > 64) out += "...";
  return out;
}

int popcount(const uint8_t* bits, size_t bytes) {
  int n = 0;
  for (size_t i = 0; i < bytes; ++i) n += std::popcount(static_cast<unsigned>(bits[i]));
  return n;
}

bool bit(const uint8_t* bits, size_t i) { return (bits[i >> 3] >> (i & 7)) & 1; }

class Walk {
 public:
  explicit Walk(std::span<const uint8_t> bytes) : bytes_(bytes) {}

  VdbStructure run();

 private:
  size_t left() const { return bytes_.size() - pos_; }

  // The file is at fault ("bytes"), at byte `at`, inside the grid being walked if any.
  [[noreturn]] void fail(size_t at, const std::string& what) const {
    std::string where = grid_ ? "grid '" + printable(grid_->name) + "' (the " + ordinal(grid_index_) + " of " +
                                    std::to_string(grid_count_) + "): "
                              : "";
    throw InvalidInput("bytes", where + what + " at byte " + std::to_string(at));
  }
  // The grid is one kiln does not read.
  [[noreturn]] void refuse_grid(const std::string& what) const {
    throw InvalidInput("grids[" + grid_->name + "]", what);
  }

  const uint8_t* take(size_t n, const std::string& what) {
    if (n > left())
      fail(pos_, "the file ends inside " + what + " (" + std::to_string(n) + " bytes needed, " +
                     std::to_string(left()) + " left)");
    const uint8_t* p = bytes_.data() + pos_;
    pos_ += n;
    return p;
  }
  template <typename T>
  T get(const std::string& what) {
    T v;
    std::memcpy(&v, take(sizeof v, what), sizeof v);
    return v;
  }
  // OpenVDB's strings (io::readString): a 32-bit length, then the bytes; the length is allocated before the read.
  std::string string(const std::string& what) {
    const size_t at = pos_;
    const uint32_t n = get<uint32_t>(what + "'s length");
    if (n > left())
      fail(at, what + " declares " + std::to_string(n) + " bytes; " + std::to_string(left()) + " are left in the file");
    const uint8_t* p = take(n, what);
    return {reinterpret_cast<const char*>(p), n};
  }

  void header();
  void metadata(const std::string& owner, bool grid);
  void delayed_load(uint32_t size, const std::string& what);
  void transform();
  void map(const std::string& type, const std::string& what);
  void grid(size_t index);
  void tree(const ValueKind& kind);
  void internal_node(const ValueKind& kind, int log2, size_t at, const std::array<int64_t, 3>& origin);
  // Widens the grid's stored box by the node or tile of `dim` voxels at `origin`.
  void store(const std::array<int64_t, 3>& origin, int64_t dim);
  void values(const ValueKind& kind, int64_t entries, int active, const std::string& what, bool decompress);
  void chunk(uint32_t compression, int64_t expected, const std::string& what, bool decompress);
  void blosc_header(const uint8_t* p, int64_t declared, int64_t expected, size_t at, const std::string& what,
                    bool padded_ok);
  void count_internal(int64_t bytes, size_t at, const std::string& what);

  std::span<const uint8_t> bytes_;
  size_t pos_ = 0;
  VdbStructure out_;
  VdbGridStructure* grid_ = nullptr;
  size_t grid_index_ = 0;
  size_t grid_count_ = 0;
  int64_t metadata_items_ = 0;
  bool half_meta_ = false;  // the grid's "is_saved_as_half_float" metadata, which decides how OpenVDB reads
  bool half_meta_seen_ = false;
};

void Walk::header() {
  if (get<int64_t>("the magic number") != kMagic) fail(0, "the file does not start with OpenVDB's magic number");
  const uint32_t version = get<uint32_t>("the file format version");
  out_.file_version = version;
  if (version < kFirstVersion || version > kLastVersion)
    fail(8, "the file format version is " + std::to_string(version) + "; kiln reads versions " +
                std::to_string(kFirstVersion) + " to " + std::to_string(kLastVersion) +
                " (save the file with a current OpenVDB)");
  get<uint32_t>("the library's major version");
  get<uint32_t>("the library's minor version");
  out_.has_grid_offsets = get<uint8_t>("the grid offset flag") != 0;
  // The UUID, as 36 characters of text (boost::uuids' operator>>, which would skip white space: refused here).
  const size_t at = pos_;
  const uint8_t* uuid = take(36, "the file's UUID");
  for (int i = 0; i < 36; ++i) {
    const bool dash = i == 8 || i == 13 || i == 18 || i == 23;
    const char c = static_cast<char>(uuid[i]);
    if (dash ? c != '-' : !std::isxdigit(static_cast<unsigned char>(c)))
      fail(at + i, "the file's UUID is not 36 characters of hexadecimal digits and dashes");
  }
}

// A MetaMap (MetaMap::readMeta): a count, then each item's name, type name, 32-bit size and value.
void Walk::metadata(const std::string& owner, bool grid) {
  const size_t count_at = pos_;
  const uint32_t count = get<uint32_t>(owner + "'s metadata count");
  metadata_items_ += count;
  if (metadata_items_ > kVdbMaxMetadataItems)
    fail(count_at, owner + " declares " + std::to_string(count) + " metadata items, which bring the file's to " +
                       std::to_string(metadata_items_) + "; at most " + std::to_string(kVdbMaxMetadataItems) +
                       " are allowed");
  for (uint32_t i = 0; i < count; ++i) {
    const std::string item = owner + "'s " + ordinal(i) + " metadata item";
    const std::string name = string(item + "'s name");
    const std::string type = string(item + "'s type name");
    const std::string what = owner + "'s metadata '" + printable(name) + "' (" + printable(type) + ")";
    const size_t at = pos_;
    const uint32_t size = get<uint32_t>(what + "'s size");
    if (size > left())
      fail(at,
           what + " declares " + std::to_string(size) + " bytes; " + std::to_string(left()) + " are left in the file");
    const auto fixed =
        std::find_if(kFixedMeta.begin(), kFixedMeta.end(), [&](const FixedMeta& f) { return f.type == type; });
    if (fixed != kFixedMeta.end()) {
      if (size != fixed->size)
        fail(at, what + " declares " + std::to_string(size) + " bytes; a " + std::string(fixed->type) + " holds " +
                     std::to_string(fixed->size));
      const uint8_t* v = take(size, what);
      if (type == "bool" && v[0] > 1) fail(at + 4, what + " holds " + std::to_string(v[0]) + "; a bool is 0 or 1");
      if (grid && name == "is_saved_as_half_float") {
        if (type != "bool") fail(at, what + " must be a bool");
        half_meta_ = v[0] == 1;
        half_meta_seen_ = true;
      }
    } else if (type == "__delayedload") {
      delayed_load(size, what);
    } else {
      // Strings and types OpenVDB does not know: their bytes, as many as declared.
      if (grid && name == "is_saved_as_half_float") fail(at, what + " must be a bool");
      take(size, what);
    }
  }
}

// io::DelayedLoadMetadata (io/DelayedLoadMetadata.cc), which io::File and io::Stream write into every grid of a
// numeric tree: a count (the grid's leaves), a per-leaf mask byte array and optionally a per-leaf int64 array, each
// raw or Blosc-compressed. The reader sizes both arrays by the count and by the Blosc header before decompressing.
void Walk::delayed_load(uint32_t size, const std::string& what) {
  if (size == 0) return;
  const size_t start = pos_;
  const size_t at = pos_;
  const uint32_t count = get<uint32_t>(what + "'s count");
  if (count > kVdbMaxLeavesPerGrid) {
    const std::string problem = what + " counts " + std::to_string(count) + " leaves; at most " +
                                std::to_string(kVdbMaxLeavesPerGrid) + " (" +
                                std::to_string(kVdbMaxLeavesPerGrid * 512) + " stored voxels) are allowed";
    if (grid_) refuse_grid(problem + " (at byte " + std::to_string(at) + ")");
    fail(at, problem);
  }
  // The two arrays OpenVDB makes, counted with the trees: a file of many grids could otherwise declare them in a few
  // hundred compressed bytes each.
  out_.tree_bytes += int64_t{count} * 9 + 288;  // each array padded by up to 128 + 16 bytes
  if (out_.tree_bytes > kVdbTreeBytes)
    fail(at, what + " brings the file's trees and their metadata to " + std::to_string(out_.tree_bytes) +
                 " bytes of OpenVDB's memory; at most " + std::to_string(kVdbTreeBytes) + " are allowed");
  for (int array = 0; array < 2; ++array) {
    const int element = array == 0 ? 1 : 8;
    const std::string part = what + (array == 0 ? "'s mask array" : "'s compressed-size array");
    const size_t size_at = pos_;
    const uint32_t stored = get<uint32_t>(part + "'s size");
    if (array == 1 && stored == std::numeric_limits<uint32_t>::max()) break;  // no compressed sizes
    const int64_t expected = int64_t{count} * element;
    if (stored == 0) {
      take(static_cast<size_t>(expected), part);
      continue;
    }
    if (stored > left())
      fail(size_at, part + " declares " + std::to_string(stored) + " bytes; " + std::to_string(left()) +
                        " are left in the file");
    if (stored < kBloscHeader)
      fail(size_at, part + " declares " + std::to_string(stored) + " Blosc bytes, less than Blosc's header");
    // OpenVDB's writer stores short arrays raw; Blosc answers 0 bytes for an empty one, which OpenVDB takes for an
    // error.
    if (expected == 0) fail(size_at, part + " is a Blosc chunk for no entries");
    const size_t data_at = pos_;
    blosc_header(take(stored, part), stored, expected, data_at, part, /*padded_ok=*/true);
  }
  const size_t used = pos_ - start;
  if (used > size)
    fail(start - 4, what + " declares " + std::to_string(size) + " bytes and holds " + std::to_string(used));
  take(size - used, what);  // OpenVDB skips what follows the arrays, up to the declared size
}

void Walk::map(const std::string& type, const std::string& what) {
  const auto kind = std::find_if(kMaps.begin(), kMaps.end(), [&](const MapKind& m) { return m.type == type; });
  if (kind == kMaps.end())
    fail(pos_, what + " is of type '" + printable(type) +
                   "', which OpenVDB does not know (AffineMap, UnitaryMap, ScaleMap, UniformScaleMap, "
                   "TranslationMap, ScaleTranslateMap, UniformScaleTranslateMap, NonlinearFrustumMap)");
  const size_t at = pos_;
  const uint8_t* p = take(8 * static_cast<size_t>(kind->doubles), what);
  for (int i = 0; i < kind->doubles; ++i) {
    double v;
    std::memcpy(&v, p + 8 * i, 8);
    if (!std::isfinite(v)) fail(at + 8 * i, what + " holds a non-finite number");
  }
}

// math::Transform::read: the map's type name, then the map.
void Walk::transform() {
  const std::string type = string("the transform's map type");
  grid_->map_type = type;
  if (type != kFrustum) return map(type, "the transform's map");
  // A frustum: its box (two Vec3d), taper and depth, then a linear map of its own.
  const size_t at = pos_;
  const uint8_t* p = take(8 * 8, "the frustum map");
  for (int i = 0; i < 8; ++i) {
    double v;
    std::memcpy(&v, p + 8 * i, 8);
    if (!std::isfinite(v)) fail(at + 8 * i, "the frustum map holds a non-finite number");
  }
  const std::string second = string("the frustum's linear map type");
  if (second == kFrustum) fail(pos_, "the frustum's linear map is itself a frustum");
  map(second, "the frustum's linear map");
}

void Walk::blosc_header(const uint8_t* p, int64_t declared, int64_t expected, size_t at, const std::string& what,
                        bool padded_ok) {
  // Blosc 1's header: version, codec version, flags, type size, then uncompressed bytes, block size and compressed
  // bytes (little-endian 32-bit). Blosc trusts these against the buffer it is given; OpenVDB gives it the chunk.
  uint32_t nbytes, blocksize, cbytes;
  std::memcpy(&nbytes, p + 4, 4);
  std::memcpy(&blocksize, p + 8, 4);
  std::memcpy(&cbytes, p + 12, 4);
  const uint8_t flags = p[2];
  // Delayed-load arrays under 128 bytes are padded to 128 before compression (points/StreamCompression.cc).
  const bool padded = padded_ok && expected < 128 && nbytes == 128;
  if (nbytes != expected && !padded)
    fail(at,
         what + " is a Blosc chunk of " + std::to_string(nbytes) + " bytes; it must hold " + std::to_string(expected));
  if (cbytes != declared)
    fail(at, what + " declares " + std::to_string(declared) + " compressed bytes but its Blosc header says " +
                 std::to_string(cbytes));
  if (p[3] == 0) fail(at, what + " has a Blosc type size of 0");
  if (flags & 0x2) {  // BLOSC_MEMCPYED: the bytes follow the header as they are
    if (cbytes != nbytes + kBloscHeader)
      fail(at, what + " is a stored (uncompressed) Blosc chunk of " + std::to_string(cbytes) + " bytes for " +
                   std::to_string(nbytes) + " bytes of data");
    return;
  }
  if (nbytes == 0) return;
  if (blocksize == 0) fail(at, what + " has a Blosc block size of 0");
  const uint64_t blocks = (uint64_t{nbytes} + blocksize - 1) / blocksize;
  const uint64_t starts_end = kBloscHeader + 4 * blocks;
  if (starts_end > cbytes)
    fail(at, what + " declares " + std::to_string(blocks) + " Blosc blocks, more than its " + std::to_string(cbytes) +
                 " bytes can hold");
  for (uint64_t b = 0; b < blocks; ++b) {
    int32_t start;
    std::memcpy(&start, p + kBloscHeader + 4 * b, 4);
    if (start < static_cast<int64_t>(starts_end) || start >= static_cast<int64_t>(cbytes))
      fail(at, what + "'s Blosc block " + std::to_string(b) + " starts at " + std::to_string(start) + ", outside its " +
                   std::to_string(cbytes) + " bytes");
  }
}

// A chunk of `expected` bytes as io::readData reads it: raw, or (zip, Blosc) a 64-bit size, negative for raw bytes,
// then that many bytes. OpenVDB allocates a positive size before reading, and reads a negative one's bytes into a
// buffer of `expected` bytes before comparing: both are checked here first.
void Walk::chunk(uint32_t compression, int64_t expected, const std::string& what, bool decompress) {
  if (!(compression & (kZip | kBlosc))) {
    take(static_cast<size_t>(expected), what);
    return;
  }
  const size_t at = pos_;
  const int64_t n = get<int64_t>(what + "'s size");
  if (n <= 0) {
    if (n != -expected)
      fail(at, what + " declares " +
                   (n == std::numeric_limits<int64_t>::min() ? std::string("2^63") : std::to_string(-n)) +
                   " uncompressed bytes; the node holds " + std::to_string(expected));
    take(static_cast<size_t>(expected), what);
    return;
  }
  if (static_cast<uint64_t>(n) > left())
    fail(at, what + " declares " + std::to_string(n) + " compressed bytes; " + std::to_string(left()) +
                 " are left in the file");
  // Both writers store a chunk raw when compressing does not make it smaller (Blosc adds its 16-byte header).
  const int64_t most = expected + ((compression & kBlosc) ? int64_t{kBloscHeader} : 64);
  if (n > most)
    fail(at, what + " declares " + std::to_string(n) + " compressed bytes for " + std::to_string(expected) +
                 " bytes of values; at most " + std::to_string(most) + " are allowed");
  if (compression & kBlosc) {
    if (n < static_cast<int64_t>(kBloscHeader))
      fail(at, what + " declares " + std::to_string(n) + " Blosc bytes, less than Blosc's header");
    blosc_header(bytes_.data() + pos_, n, expected, at + 8, what, /*padded_ok=*/false);
  }
  take(static_cast<size_t>(n), what);
  if (!decompress) return;
  // With OpenVDB's own functions, on the chunk alone: at most 32,768 values of 24 bytes, and n bytes checked above.
  std::istringstream in(std::string(reinterpret_cast<const char*>(bytes_.data() + at), 8 + static_cast<size_t>(n)));
  std::vector<char> values(static_cast<size_t>(expected));
  try {
    if (compression & kBlosc)
      openvdb::io::bloscFromStream(in, values.data(), values.size());
    else
      openvdb::io::unzipFromStream(in, values.data(), values.size());
  } catch (const std::exception& e) {
    fail(at, what + " does not decompress to its " + std::to_string(expected) + " bytes (" + e.what() + ")");
  }
}

// io::readCompressedValues: the node's metadata byte, up to two inactive values (full size even when the grid is
// stored as half floats), a selection mask, then the values: the active ones only under active-mask compression
// unless the metadata byte says all are stored.
void Walk::values(const ValueKind& kind, int64_t entries, int active, const std::string& what, bool decompress) {
  const size_t at = pos_;
  const uint8_t meta = get<uint8_t>(what + "'s metadata byte");
  if (meta > kNoMaskAndAllVals)
    fail(at, what + "'s metadata byte is " + std::to_string(meta) + "; OpenVDB writes 0 to 6");
  if (meta == 2 || meta == 4 || meta == 5) take(static_cast<size_t>(kind.size), what + "'s inactive value");
  if (meta == 5) take(static_cast<size_t>(kind.size), what + "'s second inactive value");
  if (meta == 3 || meta == 4 || meta == 5) take(static_cast<size_t>(entries / 8), what + "'s selection mask");
  const int64_t count = ((grid_->compression & kActiveMask) && meta != kNoMaskAndAllVals) ? active : entries;
  const bool half = grid_->half_float && kind.half_size > 0;
  if (half && count == 0) return;  // io::HalfReader reads nothing for no values
  chunk(grid_->compression, count * (half ? kind.half_size : kind.size), what + "'s values chunk", decompress);
}

void Walk::count_internal(int64_t bytes, size_t at, const std::string& what) {
  out_.internal_node_bytes += bytes;
  out_.tree_bytes += bytes;
  if (out_.internal_node_bytes > kVdbInternalNodeBytes)
    fail(at, what + " brings the file's internal nodes to " + std::to_string(out_.internal_node_bytes) +
                 " bytes of OpenVDB's memory; at most " + std::to_string(kVdbInternalNodeBytes) +
                 " are allowed (leaves scattered one to a node, or a damaged topology)");
  if (out_.tree_bytes > kVdbTreeBytes)
    fail(at, what + " brings the file's trees to " + std::to_string(out_.tree_bytes) +
                 " bytes of OpenVDB's memory; at most " + std::to_string(kVdbTreeBytes) + " are allowed");
}

void Walk::store(const std::array<int64_t, 3>& origin, int64_t dim) {
  for (int a = 0; a < 3; ++a) {
    grid_->stored_lo[a] = std::min(grid_->stored_lo[a], origin[a]);
    grid_->stored_hi[a] = std::max(grid_->stored_hi[a], origin[a] + dim - 1);
  }
}

// The origin of entry i of an internal node of 2^log2 entries a side at `origin`, whose children span `child_dim`
// voxels (InternalNode::offsetToLocalCoord: x slowest, z fastest).
std::array<int64_t, 3> entry_origin(const std::array<int64_t, 3>& origin, int log2, int64_t i, int64_t child_dim) {
  const int64_t side = int64_t{1} << log2;
  return {origin[0] + (i >> (2 * log2)) * child_dim, origin[1] + ((i >> log2) & (side - 1)) * child_dim,
          origin[2] + (i & (side - 1)) * child_dim};
}

// InternalNode::readTopology: child mask, value mask, the table's values, then each child in mask order; the stored
// box grows by each active tile and leaf.
void Walk::internal_node(const ValueKind& kind, int log2, size_t at, const std::array<int64_t, 3>& origin) {
  const bool upper = log2 == 5;
  const std::string what = std::string(upper ? "an upper" : "a lower") + " internal node";
  const int64_t entries = int64_t{1} << (3 * log2);
  const size_t mask_bytes = static_cast<size_t>(entries / 8);
  count_internal(upper ? upper_node_bytes(kind.size) : lower_node_bytes(kind.size), at, what);
  (upper ? grid_->upper_nodes : grid_->lower_nodes) += 1;
  const uint8_t* child_mask = take(mask_bytes, what + "'s child mask");
  const size_t value_mask_at = pos_;
  const uint8_t* value_mask = take(mask_bytes, what + "'s value mask");
  for (size_t i = 0; i < mask_bytes; ++i)
    if (child_mask[i] & value_mask[i])
      fail(value_mask_at + i, what + " marks an entry both a child and an active tile");
  // Decompressed here too: OpenVDB decompresses an internal node's values inside RootNode::readTopology, where a
  // chunk that does not decompress to its size throws and leaks the root's child.
  values(kind, entries, popcount(value_mask, mask_bytes), what, /*decompress=*/true);
  const int children = popcount(child_mask, mask_bytes);
  // Each child needs at least its masks and metadata byte (lower) or value mask (leaf): checked before the walk
  // descends, so a mask full of bits is refused at once.
  const size_t child_min = upper ? 2 * 512 + 1 : 64;
  if (static_cast<uint64_t>(children) * child_min > left())
    fail(at, what + " declares " + std::to_string(children) + " children, which need at least " +
                 std::to_string(static_cast<uint64_t>(children) * child_min) + " bytes; " + std::to_string(left()) +
                 " are left in the file");
  const int64_t child_dim = upper ? 128 : 8;
  for (int64_t i = 0; i < entries; ++i) {
    const std::array<int64_t, 3> o = entry_origin(origin, log2, i, child_dim);
    if (bit(value_mask, static_cast<size_t>(i))) store(o, child_dim);
    if (!bit(child_mask, static_cast<size_t>(i))) continue;
    if (upper) {
      internal_node(kind, 4, pos_, o);
    } else {
      store(o, 8);
      const size_t leaf_at = pos_;
      if (++grid_->leaves > kVdbMaxLeavesPerGrid)
        refuse_grid("holds more than " + std::to_string(kVdbMaxLeavesPerGrid) + " leaf nodes (the leaf at byte " +
                    std::to_string(leaf_at) + " is one more); at most " + std::to_string(kVdbMaxLeavesPerGrid) + " (" +
                    std::to_string(kVdbMaxLeavesPerGrid * 512) + " stored voxels) are allowed");
      out_.tree_bytes += leaf_bytes(kind.size);
      if (out_.tree_bytes > kVdbTreeBytes)
        fail(leaf_at, "a leaf brings the file's trees to " + std::to_string(out_.tree_bytes) +
                          " bytes of OpenVDB's memory; at most " + std::to_string(kVdbTreeBytes) + " are allowed");
      take(64, "a leaf's value mask");
    }
  }
}

// Tree::readTopology (a buffer count, then RootNode::readTopology) and Tree::readBuffers (every leaf, in the order
// of the root's table, which is sorted by origin: the walk requires children stored in that order, as OpenVDB
// writes them, so that each leaf's buffer follows in file order).
void Walk::tree(const ValueKind& kind) {
  const size_t count_at = pos_;
  const int32_t buffers = get<int32_t>("the tree's buffer count");
  if (buffers != 1) fail(count_at, "the tree declares " + std::to_string(buffers) + " buffers; OpenVDB writes 1");
  take(static_cast<size_t>(kind.size), "the tree's background value");
  const size_t tiles_at = pos_;
  const uint32_t tiles = get<uint32_t>("the root's tile count");
  const uint32_t children = get<uint32_t>("the root's child count");
  const size_t tile_bytes = 12 + static_cast<size_t>(kind.size) + 1;
  const size_t child_min = 12 + 2 * 4096 + 1;
  if (uint64_t{tiles} * tile_bytes + uint64_t{children} * child_min > left())
    fail(tiles_at, "the root declares " + std::to_string(tiles) + " tiles and " + std::to_string(children) +
                       " children, which need at least " +
                       std::to_string(uint64_t{tiles} * tile_bytes + uint64_t{children} * child_min) + " bytes; " +
                       std::to_string(left()) + " are left in the file");
  grid_->root_tiles = tiles;
  count_internal(int64_t{tiles} * root_entry_bytes(kind.size), tiles_at, "the root's tiles");
  std::vector<std::array<int32_t, 3>> keys;
  keys.reserve(size_t{tiles} + children);
  auto key = [&](const std::string& what) {
    const size_t at = pos_;
    std::array<int32_t, 3> k;
    std::memcpy(k.data(), take(12, what + "'s origin"), 12);
    for (int32_t c : k)
      if (c % kUpperDim != 0 || c < -kCoordBound || c > kCoordBound - kUpperDim)
        fail(at, what + " has origin (" + std::to_string(k[0]) + ", " + std::to_string(k[1]) + ", " +
                     std::to_string(k[2]) + "); origins are multiples of 4096 within ±2^29");
    return k;
  };
  for (uint32_t t = 0; t < tiles; ++t) {
    keys.push_back(key("the root's " + ordinal(t) + " tile"));
    take(static_cast<size_t>(kind.size), "a root tile's value");
    const size_t at = pos_;
    const uint8_t active = get<uint8_t>("a root tile's active flag");
    if (active > 1) fail(at, "a root tile's active flag is neither 0 nor 1");
    if (active) store({keys.back()[0], keys.back()[1], keys.back()[2]}, kUpperDim);
  }
  for (uint32_t c = 0; c < children; ++c) {
    const size_t at = pos_;
    keys.push_back(key("the root's " + ordinal(c) + " child"));
    if (c > 0 && !(keys[keys.size() - 2] < keys.back()))
      fail(at, "the root's children are not in increasing order of origin, as OpenVDB writes and reads them");
    count_internal(root_entry_bytes(kind.size), at, "a root child");
    internal_node(kind, 5, at, {keys.back()[0], keys.back()[1], keys.back()[2]});
  }
  // A second child at an origin replaces the first in the root's table, which leaks it; refused with any repeat.
  std::sort(keys.begin(), keys.end());
  if (std::adjacent_find(keys.begin(), keys.end()) != keys.end())
    fail(tiles_at, "the root holds two entries (tiles or children) at one origin");
}

void Walk::grid(size_t index) {
  out_.grids.emplace_back();
  grid_ = &out_.grids.back();
  grid_index_ = index;
  half_meta_ = false;
  half_meta_seen_ = false;
  // io::GridDescriptor::read: unique name, type (with "_HalfFloat" for half floats), instance parent, 3 offsets.
  const size_t desc_at = pos_;
  const std::string unique = string("a grid's name");
  for (const VdbGridStructure& g : out_.grids)
    if (&g != grid_ && g.unique_name == unique)
      fail(desc_at, "two grids have the unique name '" + printable(unique) + "' (OpenVDB's writers number repeats)");
  grid_->unique_name = unique;
  grid_->name = unique.substr(0, unique.find('\x1e'));
  std::string type = string("the grid's type name");
  constexpr std::string_view kHalf = "_HalfFloat";
  if (type.size() >= kHalf.size() && type.compare(type.size() - kHalf.size(), kHalf.size(), kHalf) == 0) {
    type.resize(type.size() - kHalf.size());
    grid_->half_float = true;
  }
  grid_->tree_type = type;
  const auto kind = std::find_if(kKinds.begin(), kKinds.end(), [&](const ValueKind& k) { return k.tree == type; });
  if (kind == kKinds.end())
    refuse_grid("is a grid of type '" + printable(type) +
                "'; kiln reads files whose grids are all float, double, int32, int64, vec3s, vec3d or vec3i trees "
                "of OpenVDB's standard 5-4-3 configuration");
  grid_->instance_parent = string("the grid's instance parent name");
  const size_t offsets_at = pos_;
  const int64_t grid_pos = get<int64_t>("the grid's offset");
  const int64_t block_pos = get<int64_t>("the grid's block offset");
  const int64_t end_pos = get<int64_t>("the grid's end offset");
  auto check_offset = [&](int64_t declared, size_t actual, const char* which, size_t at) {
    if (out_.has_grid_offsets && declared != static_cast<int64_t>(actual))
      fail(at, "the grid's " + std::string(which) + " offset is " + std::to_string(declared) +
                   "; the walk finds that part at byte " + std::to_string(actual));
  };
  check_offset(grid_pos, pos_, "start", offsets_at);
  grid_->start_offset = pos_;

  // Archive::readGrid: compression flags, metadata, transform, then (unless an instance) topology and buffers.
  const size_t compression_at = pos_;
  grid_->compression = get<uint32_t>("the grid's compression flags");
  if (grid_->compression & ~(kZip | kActiveMask | kBlosc))
    fail(compression_at, "the grid's compression flags are " + std::to_string(grid_->compression) +
                             "; OpenVDB knows 1 (zip), 2 (active mask) and 4 (blosc)");
  if ((grid_->compression & kZip) && (grid_->compression & kBlosc))
    fail(compression_at, "the grid declares both zip and blosc compression");
  metadata("the grid", /*grid=*/true);
  // OpenVDB reads the tree as half floats if the grid's metadata says so (GridBase::saveFloatAsHalf), whatever the
  // descriptor's type name said; a writer sets both.
  if (half_meta_ != grid_->half_float)
    fail(desc_at, "the grid's type name " + std::string(grid_->half_float ? "says" : "does not say") +
                      " it is stored as half floats but its is_saved_as_half_float metadata " +
                      (half_meta_seen_ ? (half_meta_ ? "says so" : "says not") : "is absent"));
  transform();
  if (grid_->instance_parent.empty()) {
    grid_->tree_offset = pos_;
    tree(*kind);
    grid_->buffers_offset = pos_;
    check_offset(block_pos, pos_, "block", offsets_at + 8);
    // Leaf buffers (LeafNode::readBuffers): the value mask again (it replaces the topology's), then the values.
    for (int64_t leaf = 0; leaf < grid_->leaves; ++leaf) {
      const std::string what = "leaf " + std::to_string(leaf) + "'s buffer";
      const uint8_t* mask = take(64, what + "'s value mask");
      // Not decompressed: a leaf buffer that does not decompress throws from readBuffers, where the tree owns every
      // node, and read_vdb reports OpenVDB's message.
      values(*kind, 512, popcount(mask, 64), what, /*decompress=*/false);
    }
  }
  check_offset(end_pos, pos_, "end", offsets_at + 16);
  grid_->end_offset = pos_;
  grid_ = nullptr;
}

VdbStructure Walk::run() {
  header();
  metadata("the file", /*grid=*/false);
  const size_t count_at = pos_;
  const int32_t count = get<int32_t>("the grid count");
  // OpenVDB reserves a descriptor per grid before reading any; every grid takes more than 64 bytes.
  if (count < 0 || count > kVdbMaxGrids || static_cast<uint64_t>(count) > left() / 64)
    fail(count_at, "the file declares " + std::to_string(count) + " grids; at most " + std::to_string(kVdbMaxGrids) +
                       " are allowed, and its " + std::to_string(left()) + " remaining bytes hold at most " +
                       std::to_string(left() / 64));
  grid_count_ = static_cast<size_t>(count);
  out_.grids.reserve(grid_count_);
  for (size_t i = 0; i < grid_count_; ++i) grid(i);
  // Instances are connected once every grid is read (Archive::connectInstance): the parent, by its unique name,
  // must be a grid with a tree of the same type, else OpenVDB throws after reading everything.
  for (const VdbGridStructure& g : out_.grids) {
    if (g.instance_parent.empty()) continue;
    const auto parent = std::find_if(out_.grids.begin(), out_.grids.end(), [&](const VdbGridStructure& p) {
      return p.instance_parent.empty() && p.unique_name == g.instance_parent;
    });
    if (parent == out_.grids.end() || parent->tree_type != g.tree_type)
      throw InvalidInput("bytes", "grid '" + printable(g.name) + "' shares the tree of '" +
                                      printable(g.instance_parent) +
                                      "', which is not a grid of the same type with a tree of its own in the file");
  }
  return out_;
}

}  // namespace

VdbStructure check_vdb_structure(std::span<const uint8_t> bytes) { return Walk(bytes).run(); }

}  // namespace kiln::volume
