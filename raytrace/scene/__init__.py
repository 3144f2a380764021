"""The scene: its model (model.py) and its readers: scene files (scene_file.py, the float32 ranges of their
values in ranges.py), meshes (meshes.py; mesh files in mesh_file.py, read by obj_file.py and ply_file.py;
meshgen.py's procedural ones), textures (textures.py, with their MIP pyramids in mipmap.py) and environment maps
(environment_map.py)."""
from .model import Camera, Cylinder, Disk, Ellipsoid, EnvironmentMap, Light, Material, MeshShape, Rectangle, Scene, Triangle
from .scene_file import load_dict, load_file, load_string, parse_scene

__all__ = ["Camera", "Cylinder", "Disk", "Ellipsoid", "EnvironmentMap", "Light", "Material", "MeshShape", "Rectangle", "Scene", "Triangle", "load_dict",
           "load_file", "load_string", "parse_scene"]
