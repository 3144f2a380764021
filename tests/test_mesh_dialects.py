"""Mesh files as real programs write them (tests/meshes/: the dialects the second hostile round found refused,
issue 43 item 16, and those that already worked), each read by raytrace and compared with trimesh's reading of
the same file vertex for vertex: lenient with the format, strict with the values.

Every file but two describes the unit square in z = 0, front side up; trimesh cuts quads as (0 1 2) (2 3 0)
where raytrace fans them as (0 1 2) (0 2 3): the same triangles, so triangles are compared by their corners in
order up to rotation. Where trimesh cannot read a file (a comment after a face, indentation, a binary vertex
element with a list and faces of mixed sizes) the expected mesh is written out here."""
from pathlib import Path

import numpy as np
import pytest
import trimesh

from raytrace.scene.mesh_file import load_mesh

CORPUS = Path(__file__).parent / "meshes"
FILES = sorted(p.name for p in CORPUS.iterdir())
SQUARE = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]]
TRIMESH_CANNOT = {  # file: (vertices, triangles) as the file means them
    "comment_after_face.obj": (SQUARE, [[0, 1, 2], [0, 2, 3]]),
    "tabs_and_indentation.obj": (SQUARE, [[0, 1, 2], [0, 2, 3]]),
    "binary_vertex_list_mixed_faces.ply": (SQUARE, [[0, 1, 2], [0, 2, 3], [0, 1, 3]]),
}
UVS = {"one_component_vt.obj": [[0.5, 0.0], [0.25, 0.0], [0.75, 0.0], [1.0, 0.0]],
       "three_component_vt.obj": [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]}


def triangles(vertices, faces):
    """Each face as its three corners, starting from its smallest corner (the order kept: orientation counts)."""
    corners = [tuple(map(tuple, np.asarray(vertices)[list(f)])) for f in faces]
    return sorted(c[c.index(min(c)):] + c[:c.index(min(c))] for c in corners)


def test_the_corpus_holds_every_dialect():
    assert len(FILES) == 20 and set(TRIMESH_CANNOT) <= set(FILES)


@pytest.mark.parametrize("name", FILES)
def test_read_as_trimesh_reads_it(name):
    mesh, dropped = load_mesh(CORPUS / name)[:2]
    assert dropped == 0 and np.isfinite(mesh.vertices).all()
    if name in TRIMESH_CANNOT:
        vertices, faces = TRIMESH_CANNOT[name]
    else:
        theirs = trimesh.load(CORPUS / name, process=False, force="mesh")
        vertices, faces = theirs.vertices, theirs.faces
        assert len(faces), "trimesh reads faces here"
    np.testing.assert_array_equal(mesh.vertices, vertices)
    assert triangles(mesh.vertices, mesh.faces) == triangles(vertices, faces)
    normals = np.cross(mesh.vertices[mesh.faces[:, 1]] - mesh.vertices[mesh.faces[:, 0]],
                       mesh.vertices[mesh.faces[:, 2]] - mesh.vertices[mesh.faces[:, 0]])
    assert (normals[:, 2] > 0).all()  # front side up, as written
    if name in UVS:
        np.testing.assert_array_equal(mesh.uvs, UVS[name])
