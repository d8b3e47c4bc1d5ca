// make_gmsh41.cpp — the unit box as Gmsh 4.8 writes it (format 4.1): every entity saved
// (Mesh.SaveAll: empty node blocks for points and curves, physical groups on points), ASCII and
// binary, then partitioned in two ($PartitionedEntities, ghost-free); and in format 2.2, ASCII and
// binary, before partitioning. The physical groups are named ($PhysicalNames). Not built by the project:
//   g++ make_gmsh41.cpp -o make_gmsh41 -lgmsh && ./make_gmsh41
#include <gmsh.h>
int main() {
  gmsh::initialize();
  gmsh::option::setNumber("General.Terminal", 0);
  gmsh::model::add("b");
  gmsh::model::occ::addBox(0, 0, 0, 1, 1, 1);
  gmsh::model::occ::synchronize();
  gmsh::model::addPhysicalGroup(3, {1}, 7);
  gmsh::model::addPhysicalGroup(0, {1, 2}, 8);
  gmsh::model::setPhysicalName(3, 7, "liver tissue");
  gmsh::model::setPhysicalName(0, 8, "anchors");
  gmsh::option::setNumber("Mesh.CharacteristicLengthMin", 2.0);  // the coarsest mesh: 14 nodes
  gmsh::option::setNumber("Mesh.CharacteristicLengthMax", 2.0);
  gmsh::model::mesh::generate(3);
  gmsh::option::setNumber("Mesh.SaveAll", 1);
  gmsh::write("box_gmsh41_saveall.msh");
  gmsh::option::setNumber("Mesh.Binary", 1);
  gmsh::write("box_gmsh41_saveall_binary.msh");
  gmsh::option::setNumber("Mesh.MshFileVersion", 2.2);
  gmsh::option::setNumber("Mesh.SaveAll", 0);
  gmsh::write("box_gmsh22_named_binary.msh");
  gmsh::option::setNumber("Mesh.Binary", 0);
  gmsh::write("box_gmsh22_named.msh");
  gmsh::option::setNumber("Mesh.MshFileVersion", 4.1);
  gmsh::option::setNumber("Mesh.SaveAll", 1);
  gmsh::model::mesh::partition(2);
  gmsh::write("box_gmsh41_partitioned.msh");
  gmsh::option::setNumber("Mesh.Binary", 1);
  gmsh::write("box_gmsh41_partitioned_binary.msh");
  gmsh::finalize();
}
