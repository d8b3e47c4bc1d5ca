#!/usr/bin/env python3
"""make_corpus.py — the seed corpora of fuzz/corpus/<target>/, from the project's own files (data/,
tests/data/) and the unit cube of tests/data/meshes/make_cube.py written in the formats the tests
build in code (binary PLY/STL, Gmsh v1, VTK). Rerun from the repository root to rebuild them; the
predictor seeds come from `fuzz_predictor` itself (FUZZ_PREDICTOR_SEEDS, see fuzz/README.md)."""
import os, shutil, struct

R = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
C = os.path.join(R, 'fuzz', 'corpus')

def put(target, name, data):
    d = os.path.join(C, target)
    os.makedirs(d, exist_ok=True)
    with open(os.path.join(d, name), 'wb') as f:
        f.write(data if isinstance(data, bytes) else data.encode())

def src(path):
    with open(os.path.join(R, path), 'rb') as f:
        return f.read()

# The unit cube: vertex i at (i&1, (i>>1)&1, (i>>2)&1); 12 outward triangles; 5 positive tets.
V = [(x, y, z) for z in (0, 1) for y in (0, 1) for x in (0, 1)]
quads = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
F = [t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))]
T = [(1, 2, 4, 7), (0, 1, 2, 4), (3, 2, 1, 7), (5, 1, 4, 7), (6, 2, 7, 4)]
def volume(t):
    p = [V[i] for i in t]
    u, v, w = ([p[k][j] - p[0][j] for j in range(3)] for k in (1, 2, 3))
    return u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0]) + u[2] * (v[0] * w[1] - v[1] * w[0])
T = [t if volume(t) > 0 else (t[0], t[1], t[3], t[2]) for t in T]  # positively oriented
g = lambda v: ' '.join(f'{x:g}' for x in v)
def normal(t):
    a, b, c = (V[i] for i in t)
    u = [b[k] - a[k] for k in range(3)]; w = [c[k] - a[k] for k in range(3)]
    return (u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0])

# --- surfaces
put('fuzz_surface_obj', 'liver.obj', src('data/meshes/liver.obj'))
put('fuzz_surface_obj', 'liver_tet_boundary.obj', src('data/meshes/liver_tet_boundary.obj'))
put('fuzz_surface_obj', 'cube_quads_groups.obj',
    'mtllib cube.mtl\no cube\n' + ''.join(f'v {g(v)}\n' for v in V) + 'vn 0 0 1\nvt 0 0\ng a\nusemtl skin\n' +
    ''.join(f'f {a+1}/1/1 {b+1}/1/1 {c+1}/1/1 {d+1}/1/1\n' for a, b, c, d in quads[:3]) + 'g b\ns 1\n' +
    ''.join(f'f {a-8} {b-8} {c-8} {d-8}\n' for a, b, c, d in quads[3:]) + 'l 1 2\np 3\n')
put('fuzz_surface_ply', 'cube_ascii.ply', src('tests/data/meshes/cube.ply'))
for endian, fmt in (('little', '<'), ('big', '>')):
    head = (f'ply\nformat binary_{endian}_endian 1.0\nelement vertex 8\nproperty float x\nproperty float y\n'
            'property float z\nelement face 12\nproperty list uchar int vertex_indices\nend_header\n').encode()
    body = b''.join(struct.pack(fmt + '3f', *v) for v in V) + b''.join(struct.pack(fmt + 'B3i', 3, *t) for t in F)
    put('fuzz_surface_ply', f'cube_binary_{endian}.ply', head + body)
for name in ('cube_binary_little.ply', 'cube_binary_big.ply', 'cube_crlf.ply'):  # as other tools write PLY
    put('fuzz_surface_ply', 'tools_' + name, src('tests/data/meshes/' + name))
put('fuzz_surface_stl', 'cube_ascii.stl', src('tests/data/meshes/cube_ascii.stl'))
put('fuzz_surface_stl', 'cube_binary.stl', b'binary cube'.ljust(80, b' ') + struct.pack('<I', len(F)) +
    b''.join(struct.pack('<12fH', *normal(t), *[x for i in t for x in V[i]], 0) for t in F))
put('fuzz_surface_off', 'cube.off', src('tests/data/meshes/cube.off'))
put('fuzz_surface_off', 'cube_coff.off', 'COFF\n# colours per vertex\n8 12 0\n' +
    ''.join(f'{g(v)} 255 0 0 255\n' for v in V) + ''.join(f'3 {a} {b} {c}\n' for a, b, c in F))

# --- tetrahedral meshes
put('fuzz_gmsh', 'liver.msh', src('data/meshes/liver.msh'))
for name in ('cube_v2.msh', 'cube_v4.msh', 'cube_v4_binary.msh', 'box_gmsh41_saveall.msh', 'box_gmsh41_saveall_binary.msh',
             'box_gmsh41_partitioned.msh', 'box_gmsh41_partitioned_binary.msh'):
    put('fuzz_gmsh', name, src('tests/data/meshes/' + name))
put('fuzz_gmsh', 'cube_v1.msh', '$NOD\n8\n' + ''.join(f'{i+1} {g(v)}\n' for i, v in enumerate(V)) +
    '$ENDNOD\n$ELM\n5\n' + ''.join(f'{e+1} 4 1 1 4 {" ".join(str(i+1) for i in t)}\n' for e, t in enumerate(T)) + '$ENDELM\n')
put('fuzz_gmsh', 'cube_v2_binary.msh', b'$MeshFormat\n2.2 1 8\n' + struct.pack('<i', 1) + b'\n$EndMeshFormat\n$Nodes\n8\n' +
    b''.join(struct.pack('<i3d', i + 1, *v) for i, v in enumerate(V)) + b'\n$EndNodes\n$Elements\n5\n' +
    struct.pack('<3i', 4, 5, 2) + b''.join(struct.pack('<7i', e + 1, 1, 1, *[i + 1 for i in t]) for e, t in enumerate(T)) +
    b'\n$EndElements\n')
put('fuzz_vtk', 'liver_tet.vtk', src('data/meshes/liver_tet.vtk'))
put('fuzz_vtk', 'cube_v3.vtk', '# vtk DataFile Version 3.0\ncube\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 8 double\n' +
    ''.join(g(v) + '\n' for v in V) + f'CELLS 5 25\n' + ''.join('4 ' + ' '.join(map(str, t)) + '\n' for t in T) +
    'CELL_TYPES 5\n' + '10\n' * 5 + 'POINT_DATA 8\nSCALARS s double 1\nLOOKUP_TABLE default\n' + '0\n' * 8)
put('fuzz_vtk', 'cube_v51.vtk', '# vtk DataFile Version 5.1\ncube\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 8 float\n' +
    ''.join(g(v) + '\n' for v in V) + 'CELLS 6 20\nOFFSETS vtktypeint64\n0 4 8 12 16 20\nCONNECTIVITY vtktypeint64\n' +
    ''.join(' '.join(map(str, t)) + '\n' for t in T) + 'CELL_TYPES 5\n' + '10\n' * 5)
sep = b'\n%%ele%%\n'
put('fuzz_tetgen', 'cube_1based', src('tests/data/meshes/cube_1based.node').rstrip(b'\n') + sep +
    src('tests/data/meshes/cube_1based.ele'))
put('fuzz_tetgen', 'liver_tet', src('data/meshes/liver_tet.node').rstrip(b'\n') + sep + src('data/meshes/liver_tet.ele'))
put('fuzz_tetgen', 'cube_0based_quadratic', '8 3 0 0\n' + ''.join(f'{i} {g(v)}\n' for i, v in enumerate(V)) + sep.decode() +
    '5 10 1\n' + ''.join(f'{e} {" ".join(map(str, t))} 0 0 0 0 0 0 {e}\n' for e, t in enumerate(T)))

# --- scenes, device CSVs
for name in sorted(os.listdir(os.path.join(R, 'data/scenes'))):
    if name.endswith('.yaml'):
        put('fuzz_scene', name, src('data/scenes/' + name))
put('fuzz_trajectory_csv', 'trajectory.csv', src('tests/data/scenes/trajectory.csv'))
put('fuzz_trajectory_csv', 'directions.csv', '# t, x, y, z, dx, dy, dz\n0,0,0.02,0,0,-1,0\n0.5,0,0.01,0\n1,0.001,0,0,0,-1,0.1\n')
put('fuzz_recording_csv', 'run.csv',
    't,tool_x,tool_y,tool_z,force_x,force_y,force_z,force_N,depth,tick,tool_qw,tool_qx,tool_qy,tool_qz,buttons,events\n' +
    ''.join(f'{i/1000:g},0,{0.01 - i*1e-4:g},0,0,{i*0.01:g},0,{i*0.01:g},0,{i},1,0,0,0,{i % 2},\n' for i in range(8)))
