"""The suite's cases in the order of its table, one module per group (see the package's docstring)."""
from .meshes import mesh_edges
from .rectangles import grazing_rectangles
from .ellipsoids import extreme_ellipsoids, grazing_ellipsoids
from .affine_shapes import extreme_disks_cylinders, grazing_disks_cylinders, rays_leaving_disks_cylinders
from .lights import lights_at_horizon
from .phong import phong_power
from .camera import extreme_fov, far_camera
from .limits import deep_accumulation, image_sizes
from .degenerate_input import degenerate_input
from .textures import textured_grazing
from .transforms import transformed_shapes
from .instances import extreme_instances, rays_leaving_instances

CASES = [mesh_edges, grazing_rectangles, grazing_ellipsoids, extreme_ellipsoids, grazing_disks_cylinders,
         extreme_disks_cylinders, rays_leaving_disks_cylinders, lights_at_horizon, phong_power,
         extreme_fov, far_camera, image_sizes, deep_accumulation, degenerate_input, textured_grazing,
         transformed_shapes, extreme_instances, rays_leaving_instances]
