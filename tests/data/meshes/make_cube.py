V=[(x,y,z) for z in (0,1) for y in (0,1) for x in (0,1)]  # index = x + 2y + 4z
sub=lambda a,b:(a[0]-b[0],a[1]-b[1],a[2]-b[2])
cross=lambda a,b:(a[1]*b[2]-a[2]*b[1],a[2]*b[0]-a[0]*b[2],a[0]*b[1]-a[1]*b[0])
dot=lambda a,b:sum(x*y for x,y in zip(a,b))
quads=[(0,2,3,1),(4,5,7,6),(0,1,5,4),(2,6,7,3),(0,4,6,2),(1,3,7,5)]
F=[]
for a,b,c,d in quads: F+= [(a,b,c),(a,c,d)]
c=(.5,.5,.5)
for f in F:
    n=cross(sub(V[f[1]],V[f[0]]),sub(V[f[2]],V[f[0]])); m=tuple((V[f[0]][k]+V[f[1]][k]+V[f[2]][k])/3 for k in range(3))
    assert dot(n,sub(m,c))>0, f
T=[(1,2,4,7),(0,1,2,4),(3,2,1,7),(5,1,4,7),(6,2,7,4)]
T2=[];vol=0
for t in T:
    p=[V[i] for i in t]; v=dot(sub(p[1],p[0]),cross(sub(p[2],p[0]),sub(p[3],p[0])))/6
    if v<0: t=(t[0],t[1],t[3],t[2]); v=-v
    T2.append(t); vol+=v
print(vol, T2)
g=lambda v:' '.join(f'{x:g}' for x in v)
with open('cube_ascii.stl','w') as f:
    f.write('solid cube\n')
    for t in F:
        n=cross(sub(V[t[1]],V[t[0]]),sub(V[t[2]],V[t[0]]))
        f.write(f'  facet normal {g(n)}\n    outer loop\n')
        for i in t: f.write(f'      vertex {g(V[i])}\n')
        f.write('    endloop\n  endfacet\n')
    f.write('endsolid cube\n')
with open('cube.ply','w') as f:
    f.write('ply\nformat ascii 1.0\ncomment unit cube, 6 quads (triangulated on load)\nelement vertex 8\nproperty float x\nproperty float y\nproperty float z\nelement face 6\nproperty list uchar int vertex_indices\nend_header\n')
    for v in V: f.write(g(v)+'\n')
    for q in quads: f.write('4 '+' '.join(map(str,q))+'\n')
# PLY as other tools write it: binary both ways, with normals, colours and per-face texture
# coordinates (8 per quad), and ASCII with CRLF line ends, doubles and 'vertex_index'.
import struct
for e,name in (('<','little'),('>','big')):
    with open(f'cube_binary_{name}.ply','wb') as f:
        f.write((f'ply\nformat binary_{name}_endian 1.0\ncomment unit cube as MeshLab-like tools write it\nobj_info palpate test\n'
                 'element vertex 8\nproperty float x\nproperty float y\nproperty float z\nproperty float nx\nproperty float ny\n'
                 'property float nz\nproperty uchar red\nproperty uchar green\nproperty uchar blue\nproperty uchar alpha\n'
                 'element face 6\nproperty list uchar uint vertex_indices\nproperty list uchar float texcoord\nend_header\n').encode())
        for v in V: f.write(struct.pack(e+'6f4B',*v,0,0,1,200,180,170,255))
        for q in quads: f.write(struct.pack(e+'B4I',4,*q)+struct.pack(e+'B8f',8,0,0,1,0,1,1,0,1))
with open('cube_crlf.ply','w',newline='') as f:
    f.write('ply\r\nformat ascii 1.0\r\nelement vertex 8\r\nproperty double x\r\nproperty double y\r\nproperty double z\r\n'
            'property uchar red\r\nelement face 6\r\nproperty list uchar int vertex_index\r\nend_header\r\n')
    for v in V: f.write(g(v)+' 255\r\n')
    for q in quads: f.write('4 '+' '.join(map(str,q))+'\r\n')
with open('cube.off','w') as f:
    f.write('OFF\n# unit cube, 12 triangles\n8 12 0\n')
    for v in V: f.write(g(v)+'\n')
    for t in F: f.write('3 '+' '.join(map(str,t))+'\n')
with open('cube_v2.msh','w') as f:
    f.write('$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n8\n')
    for i,v in enumerate(V): f.write(f'{i+1} {g(v)}\n')
    f.write('$EndNodes\n$Elements\n%d\n'%(len(T2)+2))
    f.write('1 2 2 1 1 1 3 4\n2 2 2 1 1 1 4 2\n')   # two boundary triangles (type 2) the loader skips
    for j,t in enumerate(T2): f.write(f'{j+3} 4 2 2 1 '+' '.join(str(i+1) for i in t)+'\n')
    f.write('$EndElements\n')
with open('cube_1based.node','w') as f:
    f.write('# unit cube, TetGen format, 1-based, one attribute and boundary markers\n8 3 1 1\n')
    for i,v in enumerate(V): f.write(f'{i+1}  {g(v)}  {0.5*i:g}  1  # point {i+1}\n')
with open('cube_1based.ele','w') as f:
    f.write('5 4 1  # tetrahedra, 4 nodes, region attribute\n\n')
    for j,t in enumerate(T2): f.write(f'{j+1}  '+' '.join(str(i+1) for i in t)+'  7\n')
    f.write('# written by hand for palpate tests\n')
