// The checkpoint format of the water model (save, load, slabs' in-place writes, nephos info):
// a header of the lattice, step and [water] parameters, then every population as FP32.
#include <fmt/format.h>

#include <array>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>

#include "nephos/core/atomic_file.hpp"
#include "nephos/core/error.hpp"
#include "nephos/core/hash.hpp"
#include "nephos/lbm/water_model.hpp"

namespace nephos::lbm {

namespace {
// A NaN's sign and payload depend on the order of operations (water_model.cpp): every NaN is
// stored as the one quiet NaN, 0x7FC00000.
void canonical_nans(float* v, std::size_t n) {
  for (std::size_t k = 0; k < n; ++k)
    if (std::isnan(v[k])) v[k] = std::numeric_limits<float>::quiet_NaN();
}
}  // namespace

namespace {
// Format CK4: parameters stored field by field, so that equal states give equal files, and the
// population storage; a checksum of the header, and one of each lattice row (nx populations of
// one component and direction) in a table after the populations, so that a damaged file is
// refused, not resumed. CK3 files (no checksums) and CK2 files (no storage parameter either:
// FP32 storage) still load; CK1 is refused. Populations are written as FP32 whatever the
// storage: FP16 values convert exactly, so a resumed run continues bit-identically either way.
constexpr char magic[16] = "NEPHOS-LBM-CK4";
constexpr char magic_ck3[16] = "NEPHOS-LBM-CK3";
constexpr char magic_ck2[16] = "NEPHOS-LBM-CK2";
constexpr int param_count = 19;

// A checksum of `bytes` bytes read as 32-bit words: four interleaved lanes of FNV-1a's
// xor-multiply, folded with mix64. Each step is a bijection of its word and of the lane, and the
// fold of each lane, so one damaged word always changes it.
std::uint64_t checksum(const void* data, std::size_t bytes) {
  const auto* p = static_cast<const unsigned char*>(data);
  std::uint64_t lane[4] = {0xcbf29ce484222325ULL, 0x84222325cbf29ce4ULL, 0x9e3779b97f4a7c15ULL, 0xc4ceb9fe1a85ec53ULL};
  constexpr std::uint64_t prime = 0x100000001b3ULL;
  const std::size_t words = bytes / 4;
  for (std::size_t k = 0; k < words; ++k) {
    std::uint32_t w;
    std::memcpy(&w, p + 4 * k, 4);
    lane[k % 4] = (lane[k % 4] ^ w) * prime;
  }
  for (std::size_t k = 4 * words; k < bytes; ++k) lane[0] = (lane[0] ^ p[k]) * prime;
  return mix64(mix64(mix64(lane[0] ^ bytes) ^ lane[1]) ^ lane[2]) ^ lane[3];
}

std::array<double, param_count> params_to_array(const WaterModelParams& p) {
  return {p.rho10,
          p.rho20,
          p.rest_fraction,
          p.xi_vapour,
          p.xi_temperature,
          p.g12,
          p.g22,
          p.buoyancy,
          p.buoyancy_reference,
          p.temperature_bottom,
          p.temperature_top,
          static_cast<double>(p.silos),
          p.silo_radius_min,
          p.silo_radius_max,
          p.silo_height_min,
          p.silo_height_max,
          p.vapour_background,
          p.periodic_z ? 1.0 : 0.0,
          p.storage == Storage::fp16 ? 1.0 : 0.0};
}

WaterModelParams params_from_array(const std::array<double, param_count>& a) {
  WaterModelParams p;
  p.rho10 = a[0], p.rho20 = a[1], p.rest_fraction = a[2], p.xi_vapour = a[3], p.xi_temperature = a[4];
  p.g12 = a[5], p.g22 = a[6], p.buoyancy = a[7], p.buoyancy_reference = a[8];
  p.temperature_bottom = a[9], p.temperature_top = a[10], p.silos = static_cast<int>(a[11]);
  p.silo_radius_min = a[12], p.silo_radius_max = a[13], p.silo_height_min = a[14], p.silo_height_max = a[15];
  p.vapour_background = a[16], p.periodic_z = a[17] != 0, p.storage = a[18] != 0 ? Storage::fp16 : Storage::fp32;
  return p;
}

// The checkpoint file: magic, (nx, ny, nz, step), the parameters, then both components'
// populations of the whole lattice, direction-major and unpadded (f[i * cells + cell]), every
// NaN as 0x7FC00000 (canonical_nans()).
struct CheckpointHeader {
  Grid3 grid;
  long step;
  WaterModelParams params;
  int format = 4;  // 2, 3 or 4 (read_checkpoint_header)
};

// The header's bytes before its checksum.
constexpr std::size_t checked_header_bytes = sizeof magic + 4 * sizeof(std::int64_t) + param_count * sizeof(double);
// Bytes before the populations; population i of component c at cell `cell` follows at
// ((c q + i) cells + cell) floats.
constexpr std::size_t checkpoint_header_bytes = checked_header_bytes + sizeof(std::uint64_t);

// The header's checked bytes as they lie in the file: magic, grid and step, parameters.
using HeaderBytes = std::array<char, checked_header_bytes>;
HeaderBytes header_bytes(const char (&m)[16], const std::int64_t (&hdr)[4],
                         const std::array<double, param_count>& params) {
  HeaderBytes bytes;
  std::memcpy(bytes.data(), m, sizeof m);
  std::memcpy(bytes.data() + sizeof m, hdr, sizeof hdr);
  std::memcpy(bytes.data() + sizeof m + sizeof hdr, params.data(), sizeof params);
  return bytes;
}

void write_checkpoint_header(std::ostream& os, const CheckpointHeader& h) {
  const std::int64_t hdr[4] = {h.grid.nx, h.grid.ny, h.grid.nz, h.step};
  const HeaderBytes bytes = header_bytes(magic, hdr, params_to_array(h.params));
  const std::uint64_t sum = checksum(bytes.data(), bytes.size());
  os.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  os.write(reinterpret_cast<const char*>(&sum), sizeof sum);
}
// Where population i of component c of global cell `cell` lies among a checkpoint's populations
// (in floats from their start), for a lattice of `cells` cells.
std::size_t checkpoint_value_index(int c, int i, std::size_t cells, std::size_t cell) {
  return (static_cast<std::size_t>(c) * d3q19::q + static_cast<std::size_t>(i)) * cells + cell;
}
// The row checksums' table follows the populations, one per (component, direction, z, y), in
// that order; where row (y, z) of component c, direction i lies in it.
std::size_t row_checksum_index(int c, int i, const Grid3& g, int y, int z) {
  return ((static_cast<std::size_t>(c) * d3q19::q + static_cast<std::size_t>(i)) * g.nz + z) * g.ny + y;
}
std::size_t population_bytes(const Grid3& g) { return 2 * d3q19::q * g.cells() * sizeof(float); }
// Lattice rows: one per component, direction, z and y; the row checksums' count.
std::size_t row_count(const Grid3& g) {
  return 2 * d3q19::q * static_cast<std::size_t>(g.ny) * static_cast<std::size_t>(g.nz);
}
std::size_t checkpoint_bytes(const Grid3& g) {
  return checkpoint_header_bytes + population_bytes(g) + row_count(g) * sizeof(std::uint64_t);
}
// The checksums of `rows` consecutive rows of nx values each.
void row_checksums(const float* values, int rows, int nx, std::uint64_t* out) {
  for (int r = 0; r < rows; ++r)
    out[r] = checksum(values + static_cast<std::size_t>(r) * nx, static_cast<std::size_t>(nx) * sizeof(float));
}

// The error when a checkpoint cannot be opened for writing, with the system's reason.
IoError cannot_open_for_writing(const std::filesystem::path& file) {
  return IoError(std::string("cannot open checkpoint for writing: ") + std::strerror(errno), {.file = file.string()});
}

// direction(c, i, out) fills out[cell] with population i of component c, for every cell.
void write_checkpoint(const std::filesystem::path& path, const CheckpointHeader& h,
                      const std::function<void(int, int, float*)>& direction) {
  AtomicFile out(path);
  {
    std::ofstream os(out.temp_path(), std::ios::binary);
    if (!os) throw cannot_open_for_writing(path);
    write_checkpoint_header(os, h);
    const Grid3& g = h.grid;
    std::vector<float> values(g.cells());
    std::vector<std::uint64_t> sums(row_count(g));
    for (int c = 0; c < 2; ++c)
      for (int i = 0; i < d3q19::q; ++i) {
        direction(c, i, values.data());
        canonical_nans(values.data(), values.size());
        os.write(reinterpret_cast<const char*>(values.data()),
                 static_cast<std::streamsize>(values.size() * sizeof(float)));
        row_checksums(values.data(), g.ny * g.nz, g.nx, &sums[row_checksum_index(c, i, g, 0, 0)]);
      }
    os.write(reinterpret_cast<const char*>(sums.data()), static_cast<std::streamsize>(sums.size() * sizeof(sums[0])));
    if (!os.flush()) throw IoError("checkpoint write failed (disk full?)", {.file = path.string()});
  }
  out.commit();
}

// Reads the header and leaves `is` at the populations.
CheckpointHeader read_checkpoint_header(std::ifstream& is, const std::filesystem::path& path) {
  require_input_file(path, "an lbm checkpoint");
  if (!is) throw IoError("cannot open checkpoint", {.file = path.string()});
  char m[16] = {};
  is.read(m, sizeof m);
  if (std::memcmp(m, "NEPHOS-LBM-CK1", 15) == 0)
    throw FormatError("checkpoint from an older nephos (format CK1): rerun the simulation", {.file = path.string()});
  const int format = std::memcmp(m, magic, sizeof magic) == 0           ? 4
                     : std::memcmp(m, magic_ck3, sizeof magic_ck3) == 0 ? 3
                     : std::memcmp(m, magic_ck2, sizeof magic_ck2) == 0 ? 2
                                                                        : 0;
  if (format == 0) throw FormatError("not a nephos lbm checkpoint", {.file = path.string()});
  std::int64_t hdr[4];
  is.read(reinterpret_cast<char*>(hdr), sizeof hdr);
  std::array<double, param_count> params{};  // CK2 has no storage field: FP32
  is.read(reinterpret_cast<char*>(params.data()),
          static_cast<std::streamsize>((format == 2 ? param_count - 1 : param_count) * sizeof(double)));
  if (format == 4) {  // the checksum of the bytes read so far
    const HeaderBytes bytes = header_bytes(m, hdr, params);
    std::uint64_t sum = 0;
    is.read(reinterpret_cast<char*>(&sum), sizeof sum);
    if (is && sum != checksum(bytes.data(), bytes.size()))
      throw FormatError("corrupt checkpoint header (it does not match its checksum)", {.file = path.string()});
  }
  if (!is || hdr[0] < 4 || hdr[1] < 4 || hdr[2] < 4 || hdr[0] > 4096 || hdr[1] > 4096 || hdr[2] > 4096 || hdr[3] < 0)
    throw FormatError("corrupt checkpoint header", {.file = path.string()});
  // Every parameter a number and the silo count an integer in range, before any is used (a
  // NaN would run the model into NaN densities; casting it to int is undefined).
  if (!std::all_of(params.begin(), params.end(), [](double v) { return std::isfinite(v); }) ||
      !(params[11] >= 0 && params[11] <= max_silos && params[11] == std::floor(params[11])))
    throw FormatError("corrupt checkpoint header (a parameter is not a number or out of range)",
                      {.file = path.string()});
  return {Grid3{static_cast<int>(hdr[0]), static_cast<int>(hdr[1]), static_cast<int>(hdr[2])}, hdr[3],
          params_from_array(params), format};
}

// `count` row checksums of a CK4 file from the table's entry `first` (row_checksum_index());
// none for the older formats, which have none. `populations`: where the populations start.
std::vector<std::uint64_t> read_row_checksums(std::ifstream& is, const std::filesystem::path& path,
                                              const CheckpointHeader& h, std::streamoff populations, std::size_t first,
                                              std::size_t count) {
  if (h.format < 4) return {};
  std::vector<std::uint64_t> sums(count);
  const std::size_t at = population_bytes(h.grid) + first * sizeof(std::uint64_t);
  is.seekg(populations + static_cast<std::streamoff>(at));
  is.read(reinterpret_cast<char*>(sums.data()), static_cast<std::streamsize>(sums.size() * sizeof(sums[0])));
  if (!is)
    throw FormatError(fmt::format("truncated checkpoint ({} of {} bytes)", std::filesystem::file_size(path),
                                  checkpoint_bytes(h.grid)),
                      {.file = path.string()});
  return sums;
}

// Checks rows [y0, y1) at z of component c, direction i (nx values each, in `values`) against
// their checksums (none: older formats).
void verify_rows(const std::uint64_t* sums, std::size_t rows, const float* values, const CheckpointHeader& h, int c,
                 int i, int z, int y0, const std::filesystem::path& path) {
  const std::size_t nx = static_cast<std::size_t>(h.grid.nx);
  for (std::size_t r = 0; r < rows; ++r) {
    if (checksum(values + r * nx, nx * sizeof(float)) != sums[r])
      throw FormatError(fmt::format("corrupt checkpoint: the populations of component {}, direction {}, row y = {}, "
                                    "z = {} do not match their checksum",
                                    c, i, y0 + static_cast<int>(r), z),
                        {.file = path.string()});
  }
}

}  // namespace

void WaterModel::save(const std::filesystem::path& path) const {
  if (halo_ != 0)
    throw ValueError(
        "a slab cannot save itself: create_checkpoint() the whole lattice's file, then write_owned() every slab");
  const std::size_t n = g_.cells(), stride = g_.direction_stride();
  write_checkpoint(path, {g_, step_, p_},
                   [&](int c, int i, float* out) { f_[c].read(static_cast<std::size_t>(i) * stride, n, out); });
}

WaterModel WaterModel::load(const std::filesystem::path& path) {
  std::ifstream is(path, std::ios::binary);
  const CheckpointHeader h = read_checkpoint_header(is, path);
  const std::streamoff populations = is.tellg();
  const Grid3& g = h.grid;
  // CK4: every row's checksum (8 bytes per row of nx populations: 2/nx of their size).
  std::vector<std::uint64_t> sums;
  if (h.format == 4) {
    sums = read_row_checksums(is, path, h, populations, 0, row_count(g));
    is.seekg(populations);
  }
  WaterModel w(g, h.params);
  w.step_ = h.step;
  const std::size_t n = g.cells(), stride = g.direction_stride();
  std::vector<float> values(n);
  for (int c = 0; c < 2; ++c)
    for (int i = 0; i < d3q19::q; ++i) {
      is.read(reinterpret_cast<char*>(values.data()), static_cast<std::streamsize>(n * sizeof(float)));
      if (!is) throw FormatError("truncated checkpoint", {.file = path.string()});
      for (int z = 0; !sums.empty() && z < g.nz; ++z)
        verify_rows(&sums[row_checksum_index(c, i, g, 0, z)], static_cast<std::size_t>(g.ny), &values[g.index(0, 0, z)],
                    h, c, i, z, 0, path);
      w.f_[c].write(static_cast<std::size_t>(i) * stride, n, values.data());
    }
  return w;
}

Grid3 WaterModel::checkpoint_grid(const std::filesystem::path& path) {
  std::ifstream is(path, std::ios::binary);
  return read_checkpoint_header(is, path).grid;
}

bool WaterModel::is_checkpoint(const std::filesystem::path& path) {
  std::ifstream is(path, std::ios::binary);
  char m[11] = {};
  return is.read(m, sizeof m) && std::memcmp(m, "NEPHOS-LBM-", sizeof m) == 0;
}

std::string WaterModel::describe_checkpoint(const std::filesystem::path& path) {
  std::ifstream is(path, std::ios::binary);
  const CheckpointHeader h = read_checkpoint_header(is, path);
  const std::streamoff populations = is.tellg();
  const std::uintmax_t expected =
      h.format == 4 ? checkpoint_bytes(h.grid) : static_cast<std::uintmax_t>(populations) + population_bytes(h.grid);
  const std::uintmax_t size = std::filesystem::file_size(path);
  const WaterModelParams& p = h.params;
  std::string out = fmt::format("{}\n  nephos lbm checkpoint, format CK{}\n", path.string(), h.format);
  out += fmt::format("  lattice        {} ({} cells)\n", h.grid.describe(), h.grid.cells());
  out += fmt::format("  step           {}\n", h.step);
  out += fmt::format("  storage        {}\n", p.storage == Storage::fp16 ? "fp16" : "fp32");
  out +=
      fmt::format("  populations    {}\n",
                  size == expected ? fmt::format("complete ({} bytes)", size)
                                   : fmt::format("TRUNCATED: {} of {} bytes (it cannot be resumed)", size, expected));
  out += h.format == 4 ? "  checksums      header verified; every row's populations verified when resumed\n"
                       : "  checksums      none (an older format)\n";
  out += "  [water] parameters:\n";
  const std::pair<const char*, double> values[] = {{"rho10", p.rho10},
                                                   {"rho20", p.rho20},
                                                   {"rest_fraction", p.rest_fraction},
                                                   {"xi_vapour", p.xi_vapour},
                                                   {"xi_temperature", p.xi_temperature},
                                                   {"g12", p.g12},
                                                   {"g22", p.g22},
                                                   {"buoyancy", p.buoyancy},
                                                   {"buoyancy_reference", p.buoyancy_reference},
                                                   {"temperature_bottom", p.temperature_bottom},
                                                   {"temperature_top", p.temperature_top},
                                                   {"silos", static_cast<double>(p.silos)},
                                                   {"silo_radius_min", p.silo_radius_min},
                                                   {"silo_radius_max", p.silo_radius_max},
                                                   {"silo_height_min", p.silo_height_min},
                                                   {"silo_height_max", p.silo_height_max},
                                                   {"vapour_background", p.vapour_background}};
  for (const auto& [key, v] : values) out += fmt::format("    {:<20} = {}\n", key, v);
  if (p.periodic_z) out += "  (a periodic box without top and bottom layers: a test configuration)\n";
  return out;
}

WaterModel WaterModel::load_slab(const std::filesystem::path& path, int y_begin, int y_end) {
  std::ifstream is(path, std::ios::binary);
  const CheckpointHeader h = read_checkpoint_header(is, path);
  const std::streamoff populations = is.tellg();  // CK2 headers are one parameter shorter, CK3 one checksum
  WaterModel w(h.grid, h.params, y_begin, y_end);
  w.step_ = h.step;
  // Read only the slab's rows: per (component, direction, z) one run of own x nx values
  // (cell = (z ny + y) nx + x), as write_owned() writes them. Neither memory nor reading grows
  // with the whole lattice.
  const std::size_t N = h.grid.cells(), stride = w.g_.direction_stride();
  const std::size_t run = static_cast<std::size_t>(y_end - y_begin) * static_cast<std::size_t>(h.grid.nx);
  std::vector<float> values(run);
  for (int c = 0; c < 2; ++c)
    for (int i = 0; i < d3q19::q; ++i)
      for (int z = 0; z < h.grid.nz; ++z) {
        const std::size_t first = checkpoint_value_index(c, i, N, h.grid.index(0, y_begin, z));
        is.seekg(populations + static_cast<std::streamoff>(first * sizeof(float)));
        is.read(reinterpret_cast<char*>(values.data()), static_cast<std::streamsize>(run * sizeof(float)));
        if (!is) throw FormatError("truncated checkpoint", {.file = path.string()});
        const auto sums = read_row_checksums(is, path, h, populations, row_checksum_index(c, i, h.grid, y_begin, z),
                                             static_cast<std::size_t>(y_end - y_begin));
        verify_rows(sums.data(), sums.size(), values.data(), h, c, i, z, y_begin, path);
        w.f_[c].write(static_cast<std::size_t>(i) * stride + w.g_.index(0, w.owned_begin(), z), run, values.data());
      }
  return w;
}

std::vector<float> WaterModel::pack_owned() const {
  std::vector<float> out;
  for (int y = owned_begin(); y < owned_end(); ++y) {
    const std::vector<float> r = pack_row(Exchange::populations, y);
    out.insert(out.end(), r.begin(), r.end());
  }
  return out;
}

void WaterModel::create_checkpoint(const std::filesystem::path& file, const Grid3& global,
                                   const WaterModelParams& params, long step) {
  {
    std::ofstream os(file, std::ios::binary | std::ios::trunc);
    if (!os) throw cannot_open_for_writing(file);
    write_checkpoint_header(os, {global, step, params});
    if (!os.flush()) throw IoError("checkpoint write failed (disk full?)", {.file = file.string()});
  }
  std::error_code ec;
  std::filesystem::resize_file(file, checkpoint_bytes(global), ec);
  if (ec) throw IoError("cannot size the checkpoint: " + ec.message(), {.file = file.string()});
}

void WaterModel::write_owned(const std::filesystem::path& file) const {
  // Each (component, direction, z) holds this slab's rows as one run of own x nx values in the
  // whole lattice's order (cell = (z ny + y) nx + x): 2 q nz positioned writes.
  std::fstream os(file, std::ios::binary | std::ios::in | std::ios::out);  // no truncation
  if (!os) throw cannot_open_for_writing(file);
  const std::size_t N = global_.cells(), stride = g_.direction_stride();
  const std::size_t run = static_cast<std::size_t>(owned_end() - owned_begin()) * static_cast<std::size_t>(g_.nx);
  const int rows = owned_end() - owned_begin(), y0 = global_y(owned_begin());
  std::vector<float> values(run);
  std::vector<std::uint64_t> sums(static_cast<std::size_t>(rows));
  for (int c = 0; c < 2; ++c)
    for (int i = 0; i < d3q19::q; ++i)
      for (int z = 0; z < g_.nz; ++z) {
        f_[c].read(static_cast<std::size_t>(i) * stride + g_.index(0, owned_begin(), z), run, values.data());
        canonical_nans(values.data(), run);
        const std::size_t first = checkpoint_value_index(c, i, N, global_.index(0, y0, z));
        os.seekp(static_cast<std::streamoff>(checkpoint_header_bytes + first * sizeof(float)));
        os.write(reinterpret_cast<const char*>(values.data()), static_cast<std::streamsize>(run * sizeof(float)));
        // The rows' checksums, in the table after the populations.
        row_checksums(values.data(), rows, g_.nx, sums.data());
        os.seekp(static_cast<std::streamoff>(checkpoint_header_bytes + population_bytes(global_) +
                                             row_checksum_index(c, i, global_, y0, z) * sizeof(std::uint64_t)));
        os.write(reinterpret_cast<const char*>(sums.data()),
                 static_cast<std::streamsize>(sums.size() * sizeof(sums[0])));
      }
  if (!os.flush()) throw IoError("checkpoint write failed (disk full?)", {.file = file.string()});
}

}  // namespace nephos::lbm
