"""Reads a mesh file with an independent reader and prints what it found as JSON.

Usage: python3 read_mesh.py READER FORMAT PATH, READER one of meshio, trimesh, lib3mf.
Prints {"points": N or null, "blocks": [{"name": str|null, "index": int|null,
"triangles": [[[x, y, z], [x, y, z], [x, y, z]], ...]}, ...]}, each coordinate as the
bit pattern of its f64 (an integer), so that no JSON parser can round it. lib3mf (3MF only)
reads in strict mode, fails on any warning, and adds per block whether lib3mf finds it
manifold and oriented, and the model's unit and build items. Used by
tests/output/python_readers.rs.
"""

import json
import struct
import sys


def bits(x):
    return struct.unpack("<Q", struct.pack("<d", float(x)))[0]


def corners(points, cells):
    return [[[bits(x) for x in points[i]] for i in cell] for cell in cells.tolist()]


def with_meshio(fmt, path):
    import meshio

    mesh = meshio.read(path, file_format={"obj": "obj", "msh": "gmsh", "vtu": "vtu"}[fmt])
    points = mesh.points
    blocks = []
    if fmt == "obj":
        # One cell block per `g` group; the group's number is its index among the groups.
        for block, group in zip(mesh.cells, mesh.cell_data["obj:group_ids"]):
            assert block.type == "triangle", block.type
            blocks.append({"name": None, "index": int(group[0]), "triangles": corners(points, block.data)})
        normals = mesh.point_data.get("obj:vn")
        assert normals is None or len(normals) == len(points), "normals and points disagree"
    elif fmt == "msh":
        names = {int(tag): name for name, (tag, dim) in mesh.field_data.items() if dim == 2}
        for block, physical in zip(mesh.cells, mesh.cell_data["gmsh:physical"]):
            assert block.type == "triangle", block.type
            tags = set(int(t) for t in physical)
            assert len(tags) == 1, tags
            blocks.append({"name": names[tags.pop()], "index": None, "triangles": corners(points, block.data)})
    else:
        for block, ids in zip(mesh.cells, mesh.cell_data["block"]):
            assert block.type == "triangle", block.type
            for k in sorted(set(int(i) for i in ids)):
                cells = block.data[ids == k]
                blocks.append({"name": None, "index": k, "triangles": corners(points, cells)})
    return {"points": len(points), "blocks": blocks}


def with_trimesh(fmt, path):
    import trimesh

    options = {"split_objects": True} if fmt == "obj" else {}
    scene = trimesh.load(path, file_type=fmt, process=False, force="scene", **options)
    blocks = []
    for name, geometry in scene.geometry.items():
        blocks.append({"name": name, "index": None, "triangles": corners(geometry.vertices, geometry.faces)})
    return {"points": None, "blocks": blocks}


def with_lib3mf(fmt, path):
    import lib3mf

    assert fmt == "3mf", fmt
    model = lib3mf.get_wrapper().CreateModel()
    reader = model.QueryReader("3mf")
    # Strict: what lib3mf would only warn about is an error, and a warning fails too.
    reader.SetStrictModeActive(True)
    reader.ReadFromFile(path)
    warnings = [reader.GetWarning(i) for i in range(reader.GetWarningCount())]
    assert not warnings, warnings
    blocks = []
    objects = model.GetMeshObjects()
    while objects.MoveNext():
        o = objects.GetCurrentMeshObject()
        # lib3mf holds coordinates as 32-bit floats: these are their exact values.
        points = [list(v.Coordinates) for v in o.GetVertices()]
        cells = [list(t.Indices) for t in o.GetTriangleIndices()]
        blocks.append({
            "name": o.GetName(),
            "index": None,
            "triangles": [[[bits(x) for x in points[i]] for i in cell] for cell in cells],
            "manifold": o.IsManifoldAndOriented(),
        })
    items = model.GetBuildItems()
    count = 0
    while items.MoveNext():
        count += 1
    units = {lib3mf.ModelUnit.MicroMeter: "micron", lib3mf.ModelUnit.MilliMeter: "millimeter",
             lib3mf.ModelUnit.CentiMeter: "centimeter", lib3mf.ModelUnit.Inch: "inch",
             lib3mf.ModelUnit.Foot: "foot", lib3mf.ModelUnit.Meter: "meter"}
    return {"points": None, "blocks": blocks, "unit": units[model.GetUnit()], "build_items": count}


if __name__ == "__main__":
    reader, fmt, path = sys.argv[1:]
    found = {"meshio": with_meshio, "trimesh": with_trimesh, "lib3mf": with_lib3mf}[reader](fmt, path)
    print(json.dumps(found))
