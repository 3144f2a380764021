"""A kernel's arguments, bound by name from the kernel's own declaration.

Programs are built with -cl-kernel-arg-info (program.py), so the device compiler reports each argument's
name and type. The host never restates the render kernel's argument list: it hands over named values (the
tables scene_tables.py gathers are named after the parameters of kernels/scene.h's SCENE_PARAMETERS and
TEXTURE_PARAMETERS), and every value is checked against the declared type before it is set: a struct table
against its dtype in raytrace/structs.py, a scalar or vector table against its element type, a scalar
against its numpy type. A name the kernel does not declare, a value of another type, or an argument left
unset before a launch is a KernelInterfaceError, a bug of ours and never a user's input error."""
import numpy as np
import pyopencl as cl

from ..structs import STRUCTS

SCALARS = {"int": np.dtype(np.int32), "uint": np.dtype(np.uint32), "float": np.dtype(np.float32)}
ARG_NAME, ARG_TYPE = cl.kernel_arg_info.NAME, cl.kernel_arg_info.TYPE_NAME


class KernelInterfaceError(Exception):
    pass


def declared_type(type_name):
    """(element dtype, vector width, is_pointer) of a kernel argument's type as the compiler names it:
    "Camera*", "uint2*", "float*", "int"."""
    name = type_name.replace("const", "").replace("struct", "").replace(" ", "")
    pointer = name.endswith("*")
    name = name.rstrip("*")
    if name in STRUCTS:
        return STRUCTS[name], 1, pointer
    base = name.rstrip("0123456789")
    if base not in SCALARS:
        raise KernelInterfaceError(f"argument type {type_name!r} has no host mirror")
    return SCALARS[base], int(name[len(base):] or 1), pointer


class KernelArguments:
    """The arguments of one kernel, set by name."""

    def __init__(self, kernel):
        self.kernel = kernel
        count = kernel.num_args
        self.names = [kernel.get_arg_info(i, ARG_NAME) for i in range(count)]
        self.types = [kernel.get_arg_info(i, ARG_TYPE) for i in range(count)]
        self.index = {name: i for i, name in enumerate(self.names)}
        self.unset = set(self.names)
        self.held = {}  # what each argument is set to: the kernel keeps no reference to a buffer of its own

    def _declared(self, name):
        if name not in self.index:
            raise KernelInterfaceError(f"kernel {self.kernel.function_name} has no argument {name!r} "
                                       f"(it takes: {', '.join(self.names)})")
        return declared_type(self.types[self.index[name]])

    def check(self, name, value):
        """Raise KernelInterfaceError unless `value` (a numpy array for a pointer, a numpy scalar otherwise)
        is of the type the kernel declares for `name`."""
        dtype, width, pointer = self._declared(name)
        value_dtype = getattr(value, "dtype", None)
        shape = np.shape(value)
        if pointer:
            ok = isinstance(value, np.ndarray) and value_dtype == dtype and (width == 1 or shape[-1:] == (width,))
        else:
            ok = isinstance(value, np.generic) and value_dtype == dtype and width == 1
        if not ok:
            have = f"{'array' if isinstance(value, np.ndarray) else type(value).__name__} of {value_dtype}, shape {shape}"
            raise KernelInterfaceError(f"kernel {self.kernel.function_name}: argument {name!r} is declared "
                                       f"{self.types[self.index[name]]}; the host gives an {have}")

    def set(self, name, value, buffer=None):
        """Set argument `name`: a numpy scalar, or the array whose contents `buffer` holds (checked against
        the declared type, then `buffer` is set)."""
        self.check(name, value)
        self._bind(name, value if buffer is None else buffer)

    def _bind(self, name, value):
        self.held[name] = value
        self.kernel.set_arg(self.index[name], value)
        self.unset.discard(name)

    def upload(self, context, tables):
        """Copy each named array of `tables` into a read-only buffer and set it; returns the buffers."""
        flags = cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR
        buffers = {}
        for name, array in tables.items():
            self.check(name, array)  # before the copy: a table of the wrong type is never uploaded
            buffers[name] = cl.Buffer(context, flags, hostbuf=array)
            self._bind(name, buffers[name])
        return buffers

    def launch(self, queue, global_size, local_size=None):
        """Enqueue the kernel once every argument is set; returns its event."""
        if self.unset:
            raise KernelInterfaceError(f"kernel {self.kernel.function_name}: arguments never set: "
                                       f"{', '.join(sorted(self.unset))}")
        return cl.enqueue_nd_range_kernel(queue, self.kernel, global_size, local_size)
