// export_vtk.cpp — VTK XML UnstructuredGrid (.vtu, binary appended raw, float64) and ParaView
// collection (.pvd) writers over plain arrays (palpate/export.h).
#include <palpate/export.h>

#include <fmt/format.h>

#include <bit>
#include <cstring>
#include <string>

namespace palpate {

static_assert(std::endian::native == std::endian::little, "the .vtu writer says LittleEndian");

void ExportGrid::add_cell(std::uint8_t type, std::span<const std::int64_t> ids) {
  connectivity.insert(connectivity.end(), ids.begin(), ids.end());
  offsets.push_back(std::int64_t(connectivity.size()));
  types.push_back(type);
}

namespace {

// The appended section: each block is a UInt64 byte count and the raw bytes. Blocks are laid out
// in the reverse of the order the XML names them: meshio (7.0, Debian 12) finds each block by its
// offset after rewriting the earlier ones' offsets, and a rewritten offset can equal a later
// block's, which it would then read in its place; in reverse order the one it looks for always
// comes first in the document. ParaView reads any order. `add` returns a placeholder the XML
// carries until `resolve` puts the offsets in.
class Appended {
 public:
  template <class T>
  std::string add(const T* data, size_t count) {
    const std::uint64_t n = count * sizeof(T);
    std::string block(reinterpret_cast<const char*>(&n), sizeof n);
    if (n > 0) block.append(reinterpret_cast<const char*>(data), n);
    blocks_.push_back(std::move(block));
    return fmt::format("@OFFSET{}@", blocks_.size() - 1);
  }
  // The XML with each placeholder replaced by its block's offset, and the section's bytes.
  std::string resolve(std::string xml, std::string& bytes) const {
    std::vector<std::uint64_t> offset(blocks_.size());
    bytes.clear();
    for (size_t k = blocks_.size(); k-- > 0;) {
      offset[k] = bytes.size();
      bytes += blocks_[k];
    }
    for (size_t k = 0; k < blocks_.size(); ++k) {
      const std::string token = fmt::format("@OFFSET{}@", k);
      const size_t at = xml.find(token);
      if (at != std::string::npos) xml.replace(at, token.size(), std::to_string(offset[k]));
    }
    return xml;
  }

 private:
  std::vector<std::string> blocks_;
};

std::string data_array(const char* type, const std::string& name, int components, const std::string& offset) {
  return fmt::format("        <DataArray type=\"{}\" Name=\"{}\" NumberOfComponents=\"{}\" format=\"appended\" offset=\"{}\"/>\n",
                     type, markup_escape(name), components, offset);
}

std::string arrays(const std::vector<ExportArray>& list, Appended& app, size_t tuples, const std::string& where,
                   Status& status) {
  std::string xml;
  for (const ExportArray& a : list) {
    if (a.components < 1 || a.values.size() != tuples * size_t(a.components)) {
      status = Error{fmt::format("{}: array '{}' has {} values, expected {} x {}", where, a.name, a.values.size(), tuples,
                                 a.components)};
      return {};
    }
    if (a.integer) {
      std::vector<std::int32_t> v(a.values.size());
      for (size_t i = 0; i < v.size(); ++i) v[i] = static_cast<std::int32_t>(a.values[i]);
      xml += data_array("Int32", a.name, a.components, app.add(v.data(), v.size()));
    } else {
      xml += data_array("Float64", a.name, a.components, app.add(a.values.data(), a.values.size()));
    }
  }
  return xml;
}

}  // namespace

Status write_vtu(const std::filesystem::path& file, const ExportGrid& g) {
  const std::string where = file.string();
  const size_t n = g.point_count(), cells = g.types.size();
  if (g.points.size() != 3 * n || g.offsets.size() != cells)
    return Error{where + ": inconsistent grid (points or cells)"};
  Appended app;
  Status status;
  std::string xml;
  xml += "<?xml version=\"1.0\"?>\n";
  xml += "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n";
  xml += "  <UnstructuredGrid>\n";
  if (!g.field_data.empty()) {
    xml += "    <FieldData>\n";
    for (const ExportArray& a : g.field_data) {
      if (a.values.empty() || a.values.size() % size_t(std::max(1, a.components)) != 0)
        return Error{where + ": field array '" + a.name + "' is empty or ragged"};
      const std::string off = app.add(a.values.data(), a.values.size());
      xml += fmt::format("      <DataArray type=\"Float64\" Name=\"{}\" NumberOfTuples=\"{}\" NumberOfComponents=\"{}\" "
                         "format=\"appended\" offset=\"{}\"/>\n",
                         markup_escape(a.name), a.values.size() / size_t(a.components), a.components, off);
    }
    xml += "    </FieldData>\n";
  }
  xml += fmt::format("    <Piece NumberOfPoints=\"{}\" NumberOfCells=\"{}\">\n", n, cells);
  xml += "      <PointData>\n";
  xml += arrays(g.point_data, app, n, where, status);
  if (!status) return status;
  xml += "      </PointData>\n";
  xml += "      <Points>\n";
  xml += data_array("Float64", "Points", 3, app.add(g.points.data(), g.points.size()));
  xml += "      </Points>\n";
  xml += "      <Cells>\n";
  xml += data_array("Int64", "connectivity", 1, app.add(g.connectivity.data(), g.connectivity.size()));
  xml += data_array("Int64", "offsets", 1, app.add(g.offsets.data(), g.offsets.size()));
  xml += data_array("UInt8", "types", 1, app.add(g.types.data(), g.types.size()));
  xml += "      </Cells>\n";
  xml += "    </Piece>\n";
  xml += "  </UnstructuredGrid>\n";
  std::string bytes;
  xml = app.resolve(std::move(xml), bytes);
  xml += "  <AppendedData encoding=\"raw\">\n   _";
  xml += bytes;
  xml += "\n  </AppendedData>\n</VTKFile>\n";
  return write_file_atomic(file, xml);
}

Status write_pvd(const std::filesystem::path& file, std::span<const PvdDataSet> sets) {
  std::string xml = "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n  <Collection>\n";
  for (const PvdDataSet& s : sets)
    xml += fmt::format("    <DataSet timestep=\"{:.17g}\" group=\"\" part=\"{}\" name=\"{}\" file=\"{}\"/>\n", s.time, s.part,
                       markup_escape(s.name), markup_escape(s.file));
  xml += "  </Collection>\n</VTKFile>\n";
  return write_file_atomic(file, xml);
}

}  // namespace palpate
