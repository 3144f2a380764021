"""The renderer's host side: the OpenCL device and program, the scene packed into the kernel's structs, the
BVH, the sample tables, the progressive passes and the image files (raytrace/render.py drives them)."""
