"""The Python package `surfc` (docs/python.md): check, mesh, the arrays and reports, the
errors, the constants set by keyword, the conversions to trimesh and meshio, and the GIL
released while meshing. Run from the repository's root: `python3 -m pytest python/tests`."""

from __future__ import annotations

import json
import pathlib
import subprocess
import threading
import time

import numpy as np
import pytest

import surfc

ROOT = pathlib.Path(__file__).resolve().parents[2]
TORUS = ROOT / "examples" / "torus.surf"

BALL = """
const r = 1;
surface ball = sphere(r);
mesh ball = ball { step: 0.3; start: (r, 0, 0); }
"""


def surfc_binary() -> pathlib.Path | None:
    """The command line `cargo test` built, to compare with (None if it is not there)."""
    for profile in ("debug", "release"):
        path = ROOT / "target" / profile / "surfc"
        if path.is_file():
            return path
    return None


def test_mesh_of_a_path_gives_every_block_as_arrays():
    meshes = surfc.mesh(str(TORUS))
    assert [m.name for m in meshes] == ["torus", "torus_part", "torus_closed"]
    torus = meshes[0]
    assert torus.vertices.dtype == np.float64 and torus.vertices.shape[1] == 3
    assert torus.normals.shape == torus.vertices.shape
    assert torus.triangles.dtype == np.uint32 and torus.triangles.shape[1] == 3
    assert torus.triangles.max() < len(torus.vertices)
    assert np.allclose(np.linalg.norm(torus.normals, axis=1), 1.0)
    # The report is that of `surfc mesh --json`: a closed torus.
    report = torus.report
    assert report["name"] == "torus"
    assert report["triangles"] == len(torus.triangles)
    assert (report["boundary_edges"], report["euler_characteristic"]) == (0, 0)
    assert "Mesh(name='torus'" in repr(torus)


def test_a_path_like_and_source_text_mesh_alike():
    from_path = surfc.mesh(TORUS)
    from_text = surfc.mesh(TORUS.read_text())
    for a, b in zip(from_path, from_text):
        assert np.array_equal(a.vertices, b.vertices)
        assert np.array_equal(a.triangles, b.triangles)


def test_the_report_is_the_command_lines():
    binary = surfc_binary()
    if binary is None:
        pytest.skip("no surfc binary in target/ to compare with")
    report = subprocess.run(
        [str(binary), "mesh", str(TORUS), "-o", "/dev/null", "--format", "obj", "--json"],
        capture_output=True,
        check=True,
    )
    blocks = json.loads(report.stdout)["meshes"]
    for block, mesh in zip(blocks, surfc.mesh(TORUS)):
        assert block.keys() == mesh.report.keys()
        for key in ("name", "triangles", "vertices", "euler_characteristic", "min_angle_deg"):
            assert block[key] == mesh.report[key], key
        assert block["triangles"] == len(mesh.triangles)


def test_keywords_set_constants_as_minus_d_does():
    small, large = surfc.mesh(BALL)[0], surfc.mesh(BALL, r=2)[0]
    assert np.isclose(np.linalg.norm(small.vertices, axis=1).max(), 1.0, atol=1e-6)
    assert np.isclose(np.linalg.norm(large.vertices, axis=1).max(), 2.0, atol=1e-6)
    assert len(large.triangles) > len(small.triangles)
    assert surfc.check(BALL, r=3).constants == {"r": 3.0}


def test_an_unknown_constant_lists_the_known_ones():
    with pytest.raises(surfc.SurfcError) as caught:
        surfc.mesh(BALL, radius=2)
    assert caught.value.codes == ["E0701"]
    assert "r" in (caught.value.diagnostics[0]["help"] or "")


@pytest.mark.parametrize("value", ["2", None, True, float("inf")])
def test_a_constant_is_a_finite_number(value):
    with pytest.raises((TypeError, ValueError)):
        surfc.mesh(BALL, r=value)


def test_check_gives_names_and_raises_with_the_rendered_diagnostics():
    checked = surfc.check(BALL)
    assert (checked.surfaces, checked.meshes, checked.warnings) == (["ball"], ["ball"], "")
    with pytest.raises(surfc.SurfcError) as caught:
        surfc.check("surface s = x + qq;\nsurface t = y + ww;\n")
    error = caught.value
    assert isinstance(error, ValueError)
    assert error.codes == ["E0101", "E0101"]
    text = str(error)
    assert "error[E0101]: unknown name `qq`" in text
    assert "<source>:1:17" in text and "<source>:2:17" in text
    first = error.diagnostics[0]
    assert (first["file"], first["line"], first["column"]) == ("<source>", 1, 17)


def test_errors_in_a_file_name_the_file(tmp_path):
    broken = tmp_path / "broken.surf"
    broken.write_text("surface s = sphere(1;\n")
    with pytest.raises(surfc.SurfcError) as caught:
        surfc.check(broken)
    assert f"{broken}:1:" in str(caught.value)
    assert caught.value.diagnostics[0]["file"] == str(broken)


def test_imports_are_relative_to_the_file(tmp_path):
    (tmp_path / "lib").mkdir()
    (tmp_path / "lib" / "shape.surf").write_text("const r = 2;\n")
    main = tmp_path / "main.surf"
    main.write_text(
        'import "lib/shape.surf";\nsurface ball = sphere(r);\n'
        "mesh ball = ball { step: 0.4; start: (r, 0, 0); }\n"
    )
    (ball,) = surfc.mesh(str(main))
    assert np.isclose(np.linalg.norm(ball.vertices, axis=1).max(), 2.0, atol=1e-6)


def test_a_missing_file_is_an_os_error():
    with pytest.raises(FileNotFoundError, match="missing.surf"):
        surfc.mesh("missing.surf")


def test_a_mesh_that_cannot_be_completed_is_an_error():
    source = (
        "surface ball = sphere(1);\n"
        "mesh ball = ball { step: 0.1; start: (1, 0, 0); max_triangles: 10; }\n"
    )
    with pytest.raises(surfc.SurfcError) as caught:
        surfc.mesh(source)
    assert caught.value.codes == ["E0601"]


def test_a_source_without_meshes_meshes_nothing():
    assert surfc.mesh("surface s = sphere(1);") == []


def test_to_trimesh_and_to_meshio():
    torus = surfc.mesh(TORUS)[0]
    trimesh = pytest.importorskip("trimesh")
    t = torus.to_trimesh()
    assert isinstance(t, trimesh.Trimesh)
    assert t.is_watertight and t.euler_number == 0
    assert len(t.vertices) == len(torus.vertices)
    meshio = pytest.importorskip("meshio")
    m = torus.to_meshio()
    assert isinstance(m, meshio.Mesh)
    assert np.array_equal(m.cells_dict["triangle"], torus.triangles)


def test_other_threads_run_while_it_meshes():
    # A counter thread advances while mesh() runs only if mesh() released the GIL.
    ticks = []
    done = threading.Event()

    def count():
        while not done.is_set():
            ticks.append(time.perf_counter())
            time.sleep(0.001)

    source = (
        "surface ball = sphere(1);\nmesh ball = ball { step: 0.03; start: (1, 0, 0); }\n"
    )
    counter = threading.Thread(target=count)
    counter.start()
    started = time.perf_counter()
    surfc.mesh(source)
    took = time.perf_counter() - started
    done.set()
    counter.join()
    during = [t for t in ticks if started < t < started + took]
    assert took < 0.05 or len(during) > 5, (took, len(during))
