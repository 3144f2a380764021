"""raytrace/renderer/program.py's build: a compiler's log is no warning on stderr unless the user asks for it
(pyopencl's PYOPENCL_COMPILER_OUTPUT). NVIDIA's compiler logs on every build, and pyopencl turns any log into
a CompilerWarning, which would put a second line on stderr under every command that promises one."""
import uuid
import warnings

import pyopencl as cl

from raytrace.renderer.program import build

# A build whose log is not empty: PoCL's clang logs the preprocessor's #warning, NVIDIA's compiler a note on
# every kernel. Each build's source is new (the comment), since a driver's own cache returns a build seen
# before with an empty log (NVIDIA's did: the second test failed on an H100 with one source for both).
SOURCE = '#warning "a line in the build log"\n__kernel void k(__global float *x) {{ x[0] = 1.0f; }} /* {} */\n'


def compiler_warnings(context):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        build(context, SOURCE.format(uuid.uuid4()))
    return [str(w.message) for w in caught if issubclass(w.category, cl.CompilerWarning)]


def test_a_build_log_is_no_warning(cl_env, monkeypatch):
    monkeypatch.delenv("PYOPENCL_COMPILER_OUTPUT", raising=False)
    assert compiler_warnings(cl_env[0]) == []


def test_the_log_is_shown_on_request(cl_env, monkeypatch):
    """The first test's build has a log to hide: asked for, it is there."""
    monkeypatch.setenv("PYOPENCL_COMPILER_OUTPUT", "1")
    assert compiler_warnings(cl_env[0])
