// msh_check_v2.cpp — the checks of a .msh file of formats 1 and 2 (io/msh_check.h).
#include "io/msh_check.h"
#include "io/text_lines.h"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <cmath>
#include <fstream>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

namespace palpate::io {

// Formats 1 and 2: the file read as Gmsh 4.8's reader for them (GModel::_readMSH2) reads it,
// section by section: a line is a section when its first byte is '$', named by prefix ("$Nodesx"
// is $Nodes), found by fgets' 255-byte reads right through binary data; after what a section's
// reader read, the next line opening with '$' (its end, normally) is read as a section. Checked on
// the way, before Gmsh reads any of it: every count against the file's size; every element's type
// (1..15), tags and nodes, each node one the last $Nodes section defines (Gmsh dereferenced a null
// node for one no node has: a format-4 body under a "2.2" header crashed `palpate info`); in binary,
// each element block's header against the bytes left (Gmsh allocates each block's element, 1 +
// tags + nodes ints, by the header: 2e9 tags made it ask for 7.8 GB), and the byte-order int. All
// found by fuzzing, the last by a damaged "\xa5$Nodes" line palpate's old line scan passed over
// while Gmsh's fgets found an element block behind it and asked for 2.16 GB.
Status check_msh2(const std::string& t, double max_count, const std::string& name) {
  StdioWalk f(t);
  std::string str = "x";  // Gmsh's fgets buffer
  double version = 1.0;
  bool binary = false;
  std::vector<long long> ids;  // the node numbers of the last $Nodes section, sorted
  std::string nodes_name = "$Nodes";
  const auto error = [&](int line, const std::string& what) { return Error{fmt::format("{}:{}: {}", name, line, what)}; };
  // A count on the line after a section's name (Gmsh: fgets, then sscanf "%d").
  const auto count = [&](const std::string& shown, const char* what, long long& n) -> Status {
    const int line = f.gets_line() + 1;
    if (!f.gets(str) || std::sscanf(str.c_str(), "%lld", &n) != 1)  // Gmsh reads on with whatever it has then
      return error(line, fmt::format("expected the number of {} after {}", what, shown));
    if (n < 0 || static_cast<double>(n) > max_count)
      return error(line, fmt::format("{} promises {} {}, more than the file can hold", shown, n, what));
    return {};
  };
  while (true) {
    while (str.empty() || str[0] != '$')
      if (!f.gets(str) || f.eof()) break;
    if (f.eof()) break;
    const std::string section(after_first(str));
    const std::string shown = section_shown(section);
    const int section_line = f.gets_line();
    if (starts(section, "MeshFormat")) {
      int format = 0, size = 0;
      if (!f.gets(str) || f.eof() || std::sscanf(str.c_str(), "%lf %d %d", &version, &format, &size) != 3)
        return error(section_line + 1, "expected the version, file type and data size after $MeshFormat");
      if (format) {  // binary from here on (Gmsh never sets it back)
        binary = true;
        if (Status s = check_byte_order(f, section_line + 2, name); !s) return s;
      }
    } else if (starts(section, "PhysicalNames")) {
      long long n = 0;
      if (Status s = count(shown, "names", n); !s) return s;
      for (long long i = 0; i < n; ++i) {
        long long v = 0;
        if ((version > 2.0 && !f.scan_int(v)) || !f.scan_int(v) || !f.gets(str))
          return error(f.token_line(), fmt::format("{}: expected name {} of {} (dimension, number, \"name\")", shown,
                                                   i + 1, n));
      }
    } else if (starts(section, "ParametricNodes")) {
      // Nodes tied to CAD entities a format-2 file does not hold: Gmsh 4.8 left a node of an entity
      // dimension outside 0..3 unset and dereferenced it (found by fuzzing: `palpate info` segfaulted).
      return error(section_line, fmt::format("{}: parametric nodes are not read; save the mesh without "
                                             "Mesh.SaveParametric",
                                             shown));
    } else if (starts(section, "NO") || starts(section, "Nodes")) {
      nodes_name = shown;
      long long n = 0;
      if (Status s = count(shown, "nodes", n); !s) return s;
      ids.clear();
      ids.reserve(static_cast<size_t>(n));
      for (long long i = 0; i < n; ++i) {
        long long id = 0;
        double x[3];
        bool ok = true;
        if (binary) {
          std::int32_t number = 0;
          ok = f.read(&number, 4) && f.read(x, 24);
          id = number;
        } else {
          ok = f.scan_int(id) && f.scan_double(x[0]) && f.scan_double(x[1]) && f.scan_double(x[2]);
        }
        if (!ok)
          return binary ? error(section_line + 1, fmt::format("{} (binary): unexpected end of file in node {} of {}",
                                                              shown, i + 1, n))
                        : error(f.token_line(), fmt::format("{}: expected node {} of {} (its number, then x y z)",
                                                            shown, i + 1, n));
        ids.push_back(id);
      }
      std::sort(ids.begin(), ids.end());
    } else if (starts(section, "ELM") || starts(section, "Elements")) {
      long long n = 0;
      if (Status s = count(shown, "elements", n); !s) return s;
      const int count_line = f.gets_line();
      const auto defined = [&](long long node) { return std::binary_search(ids.begin(), ids.end(), node); };
      // Tags after the physical and elementary ones are partitions, parents and domains: Gmsh 4.8
      // turns them into partitioned entities and crashed doing so on damaged ones (found by
      // fuzzing: a "2.2"-less version 1.2 file, `palpate info` segfaulted). Only 0 (none) is read.
      const auto extra_tags = [&](long long element, long long value) {
        return fmt::format("element {} has partition or parent tag {}: palpate reads format-2 meshes without "
                           "partitions (save as format 4.1)",
                           element, value);
      };
      if (binary) {
        const size_t body = f.at();
        const auto block_error = [&](const std::string& what) {
          return error(count_line, fmt::format("{} (binary, byte {} of the section): {}", shown, f.at() - body, what));
        };
        long long sum = 0;
        for (long long b = 0; sum < n; ++b) {
          std::int32_t header[3];
          if (!f.read(header, 12)) return block_error(fmt::format("unexpected end of file in block {}", b));
          const std::int32_t type = header[0], elements = header[1], tags = header[2];
          if (type < 1 || type > 15) return block_error(fmt::format("block {}: element type {} is not read", b, type));
          const long long ints = 1LL + tags + kNodesOfType[type];
          if (elements < 1 || tags < 0 || elements > n - sum ||
              static_cast<double>(elements) * static_cast<double>(ints) * 4.0 > static_cast<double>(t.size() - f.at()))
            return block_error(fmt::format("block {} ({} elements of type {} with {} tags each) does not fit the file "
                                           "or the total of {}",
                                           b, elements, type, tags, n));
          std::vector<std::int32_t> data(static_cast<size_t>(ints));
          for (std::int32_t e = 0; e < elements; ++e) {
            f.read(data.data(), data.size() * 4);  // fits: checked above
            for (std::int32_t k = 2; k < tags; ++k)
              if (data[static_cast<size_t>(1 + k)] != 0) return block_error(extra_tags(data[0], data[static_cast<size_t>(1 + k)]));
            for (int k = 0; k < kNodesOfType[type]; ++k) {
              const std::int32_t node = data[static_cast<size_t>(1 + tags + k)];
              if (!defined(node))
                return block_error(fmt::format("element {} names node {}, which {} does not define", data[0], node,
                                               nodes_name));
            }
          }
          sum += elements;
        }
      } else {
        for (long long i = 0; i < n; ++i) {
          // Format 1 (Gmsh: version <= 1.0): number, type, two region tags, node count, nodes.
          // Later: number, type, tag count, tags, nodes.
          long long head[5] = {0, 0, 0, 0, 0};
          const int fields = version <= 1.0 ? 5 : 3;
          for (int k = 0; k < fields; ++k)
            if (!f.scan_int(head[k]))
              return error(f.token_line(), fmt::format("{}: expected element {} of {} (number, type, {})", shown, i + 1, n,
                                                       version <= 1.0 ? "regions, node count, nodes" : "tags, nodes"));
          const long long type = head[1];
          if (type < 1 || type > 15)
            return error(f.token_line(), fmt::format("{}: element {}: type {} is not read", shown, head[0], type));
          const long long tags = version <= 1.0 ? 0 : head[2];
          const long long nodes = version <= 1.0 ? head[4] : kNodesOfType[type];
          if (tags < 0 || tags > 64 || nodes != kNodesOfType[type])
            return error(f.token_line(), fmt::format("{}: element {}: {} tags and {} nodes for type {} (expected {} nodes)",
                                                     shown, head[0], tags, nodes, type, kNodesOfType[type]));
          for (long long k = 0; k < tags + nodes; ++k) {
            long long v = 0;
            if (!f.scan_int(v))
              return error(f.token_line(), fmt::format("{}: element {}: expected {} integers after its type", shown,
                                                       head[0], tags + nodes));
            if (k >= 2 && k < tags && v != 0) return error(f.token_line(), shown + ": " + extra_tags(head[0], v));
            if (k >= tags && !defined(v))
              return error(f.token_line(), fmt::format("{}: element {} names node {}, which {} does not define", shown,
                                                       head[0], v, nodes_name));
          }
        }
      }
    } else if (starts(section, "InterpolationScheme") || starts(section, "NodeData") ||
               starts(section, "ElementData") || starts(section, "ElementNodeData")) {
      // Post-processing views: Gmsh sizes their arrays by counts inside them; palpate has no use for them.
      return error(section_line, fmt::format("{}: post-processing data is not read; save the mesh without it", shown));
    }
    do {  // on to the next line that opens with '$' (normally the section's end, itself read as a section)
      if (!f.gets(str) || f.eof()) break;
    } while (str[0] != '$');
  }
  return {};
}

}  // namespace palpate::io
