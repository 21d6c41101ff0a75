#include "nephos/io/netcdf_writer.hpp"

#include <algorithm>

#include <fmt/format.h>
#include <netcdf.h>

#include "nephos/core/atomic_file.hpp"
#include "nephos/core/error.hpp"

namespace nephos::io {

NetcdfWriter::NetcdfWriter(const std::filesystem::path& path) : path_(path), file_(std::make_unique<AtomicFile>(path)) {
  check(nc_create(file_->temp_path().c_str(), NC_NETCDF4 | NC_CLOBBER, &ncid_), "cannot create");
}

NetcdfWriter::~NetcdfWriter() {
  if (ncid_ >= 0) nc_close(ncid_);  // the AtomicFile then removes the temporary
}

void NetcdfWriter::check(int status, const std::string& what) const {
  if (status != NC_NOERR) throw IoError(what + ": " + nc_strerror(status), {.file = path_.string()});
}

const NetcdfWriter::Dimension& NetcdfWriter::dimension(const std::string& name) const {
  for (const Dimension& d : dims_)
    if (d.name == name) return d;
  throw ValueError("unknown dimension '" + name + "'", {.file = path_.string()});
}

int NetcdfWriter::add_dimension(const std::string& name, std::size_t length) {
  int id = 0;
  check(nc_def_dim(ncid_, name.c_str(), length, &id), "cannot define dimension " + name);
  dims_.push_back({name, id, length});
  return id;
}

int NetcdfWriter::add_variable(const std::string& name, NcType type, const std::vector<std::string>& dims,
                               const std::vector<std::size_t>& chunks) {
  if (!chunks.empty() && chunks.size() != dims.size())
    throw ValueError(fmt::format("variable {}: {} chunk lengths for {} dimensions", name, chunks.size(), dims.size()),
                     {.file = path_.string()});
  std::vector<int> ids;
  std::vector<std::size_t> chunk;
  for (std::size_t k = 0; k < dims.size(); ++k) {
    const Dimension& d = dimension(dims[k]);
    ids.push_back(d.id);
    if (!chunks.empty()) chunk.push_back(std::clamp<std::size_t>(chunks[k], 1, std::max<std::size_t>(d.length, 1)));
  }
  const nc_type t = type == NcType::f32   ? NC_FLOAT
                    : type == NcType::f64 ? NC_DOUBLE
                    : type == NcType::i32 ? NC_INT
                    : type == NcType::i16 ? NC_SHORT
                                          : NC_BYTE;
  int var = 0;
  check(nc_def_var(ncid_, name.c_str(), t, static_cast<int>(ids.size()), ids.data(), &var),
        "cannot define variable " + name);
  // Shuffle + deflate level 1: float fields compress little past it, and higher levels cost
  // far more time to write (docs/PERFORMANCE.md, design choices).
  if (!dims.empty()) check(nc_def_var_deflate(ncid_, var, 1, 1, 1), "cannot enable compression for " + name);
  if (!chunk.empty()) check(nc_def_var_chunking(ncid_, var, NC_CHUNKED, chunk.data()), "cannot chunk " + name);
  return var;
}

void NetcdfWriter::put_attribute(int var, const std::string& name, const std::string& value) {
  check(nc_put_att_text(ncid_, var == global ? NC_GLOBAL : var, name.c_str(), value.size(), value.c_str()),
        "cannot write attribute " + name);
}
void NetcdfWriter::put_attribute(int var, const std::string& name, double value) {
  check(nc_put_att_double(ncid_, var == global ? NC_GLOBAL : var, name.c_str(), NC_DOUBLE, 1, &value),
        "cannot write attribute " + name);
}
void NetcdfWriter::put_attribute(int var, const std::string& name, const std::vector<double>& values) {
  check(
      nc_put_att_double(ncid_, var == global ? NC_GLOBAL : var, name.c_str(), NC_DOUBLE, values.size(), values.data()),
      "cannot write attribute " + name);
}
void NetcdfWriter::put_attribute_f32(int var, const std::string& name, const std::vector<float>& values) {
  check(nc_put_att_float(ncid_, var == global ? NC_GLOBAL : var, name.c_str(), NC_FLOAT, values.size(), values.data()),
        "cannot write attribute " + name);
}
void NetcdfWriter::put_attribute_i8(int var, const std::string& name, const std::vector<std::int8_t>& values) {
  check(nc_put_att_schar(ncid_, var == global ? NC_GLOBAL : var, name.c_str(), NC_BYTE, values.size(),
                         reinterpret_cast<const signed char*>(values.data())),
        "cannot write attribute " + name);
}

void NetcdfWriter::put_attribute_i16(int var, const std::string& name, const std::vector<std::int16_t>& values) {
  check(nc_put_att_short(ncid_, var == global ? NC_GLOBAL : var, name.c_str(), NC_SHORT, values.size(), values.data()),
        "cannot write attribute " + name);
}

void NetcdfWriter::put_attribute_u64(int var, const std::string& name, std::uint64_t value) {
  const unsigned long long v = value;
  check(nc_put_att_ulonglong(ncid_, var == global ? NC_GLOBAL : var, name.c_str(), NC_UINT64, 1, &v),
        "cannot write attribute " + name);
}

void NetcdfWriter::end_definitions() { check(nc_enddef(ncid_), "cannot leave define mode"); }
void NetcdfWriter::write(int var, const float* data) { check(nc_put_var_float(ncid_, var, data), "cannot write data"); }
void NetcdfWriter::write(int var, const double* data) {
  check(nc_put_var_double(ncid_, var, data), "cannot write data");
}
void NetcdfWriter::write(int var, const std::int32_t* data) {
  check(nc_put_var_int(ncid_, var, data), "cannot write data");
}
void NetcdfWriter::write(int var, const std::int8_t* data) {
  check(nc_put_var_schar(ncid_, var, reinterpret_cast<const signed char*>(data)), "cannot write data");
}

void NetcdfWriter::write(int var, const std::int16_t* data) {
  check(nc_put_var_short(ncid_, var, data), "cannot write data");
}

void NetcdfWriter::close() {
  const int status = nc_close(ncid_);
  ncid_ = -1;
  check(status, "cannot close");
  file_->commit();
}

}  // namespace nephos::io
