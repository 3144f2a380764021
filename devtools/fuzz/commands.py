"""Hypothesis strategies for the renderer's command line and environment: `render` argument vectors with
valid and hostile option values, output names and flags (CommandLine), command lines whose outputs alias an
input (AliasingCommand), and environment variables the renderer, PoCL and the OpenCL loader read, with odd
values."""
import dataclasses
import os

from hypothesis import strategies as st

from .scenes import SAMPLERS

# --- hostile command lines -----------------------------------------------------------------------------

HOSTILE_NUMBERS = ("0", "-1", "1", "2", "4", "5", "9", "16", "17", "65536", "65537", "16384", "16385",
                   "2147483648", "4294967295", "4294967296", "99999999999999999999", "1.5", "1e3", "8.0", "nan", "inf",
                   "-inf", "1e-300", "1e308", "1e-320", "-0", "-0.0", "", " ", "0x10", "1_0", "٨", "８", "+4", " 4 ",
                   "−1", "None")
HOSTILE_WORDS = ("", " ", "grid", "center", "sobol", "halton", "random", "rotated-grid-cw", "GRID", "grid ",
                 "trilinear", "nearest", "anisotropic", "none", "é", "a\nb", "-", "--", "cpu", "gpu", "CPU", "0:0",
                 "0:1", "1:0", "0:0:0", "0:0:", ":", "0:", ":0", "-1:0", "00:00", "٠:٠", "99999999999999999999:0",
                 "pthread", "Portable", "accelerator", "custom", "all")
NUMERIC_OPTIONS = ("--width", "--height", "--spp", "--light-samples", "--seed", "--time-limit", "--target-error")
TEXT_OPTIONS = ("--sampler", "--light-sampler", "--texture-filter", "--device", "--scheduler")
# Scheduler addresses that must each be one line, and none of which starts a cluster (that takes seconds):
# bad forms, TLS, ports nothing listens on (the probe's refusal; servers that misbehave are
# tests/test_hostile_commands.py's).
HOSTILE_SCHEDULERS = ("", " ", "local:0", "local:257", "local:", "local:x", "local:-1", "local:１", "tls://127.0.0.1:1",
                      "tcp://127.0.0.1:1", "tcp://127.0.0.1:", "tcp://:1", "tcp://[::1]:1", "udp://x:1", "tcp://a b:1",
                      "inproc://x", "local:99999999999999999999")
VALID_OPTION_VALUES = {
    "--width": st.integers(1, 16).map(str), "--height": st.integers(1, 16).map(str),
    "--spp": st.sampled_from(["1", "4", "9"]), "--light-samples": st.sampled_from(["1", "4"]),
    "--sampler": st.sampled_from(SAMPLERS), "--light-sampler": st.sampled_from(SAMPLERS),
    "--texture-filter": st.sampled_from(["nearest", "bilinear", "trilinear", "anisotropic"]),
    "--seed": st.integers(0, 2**32 - 1).map(str), "--time-limit": st.sampled_from(["0.001", "1", "60", "1e9"]),
    "--target-error": st.sampled_from(["1e-9", "0.01", "1", "1e30"]),
    "--device": st.sampled_from(["cpu", "CPU", "0:0", "Portable", "pthread"]),
    "--scheduler": st.sampled_from(["tcp://127.0.0.1:1"]),  # no valid address without a cluster: refused too
}
OUTPUT_EXTENSIONS = (".png", ".exr", ".jpg", ".jpeg", ".bmp", ".tga", ".tif", ".tiff", ".hdr", ".PNG", ".Exr",
                     ".gif", ".webp", ".ppm", ".toml", "", ".", ".png.", ".exr.tmp")
OUTPUT_STEMS = ("out", "ü", "a b", ".hidden", "sub/out", "missing/out", "taken", "-", "a\nb", "x" * 300, "scene")


def device_specs():
    """--device values shaped like its "P:D" indices, with too many or too few parts, signs, odd digits."""
    digits = st.sampled_from(["0", "1", "7", "٠", "00", "99999999999999999999"])
    parts = st.one_of(digits, st.sampled_from(["", "-1", " 0", "x"]))
    return st.one_of(st.sampled_from([2, 3, 4]).flatmap(lambda n: st.lists(digits, min_size=n, max_size=n)),
                     st.lists(parts, min_size=1, max_size=4)).map(":".join)


def hostile_option_values(option):
    text = st.text(st.characters(blacklist_categories=["Cs"], blacklist_characters="\x00"), max_size=8)
    words = HOSTILE_NUMBERS if option in NUMERIC_OPTIONS else HOSTILE_SCHEDULERS if option == "--scheduler" \
        else HOSTILE_WORDS
    shaped = device_specs() if option == "--device" else st.sampled_from(words)
    if option == "--scheduler":  # random text could name a reachable cluster or start a local one
        return st.one_of(st.sampled_from(words), st.sampled_from(HOSTILE_WORDS))
    return st.one_of(st.sampled_from(words), shaped, st.sampled_from(HOSTILE_NUMBERS + HOSTILE_WORDS), text,
                     st.integers().map(str), st.floats().map(repr))


@dataclasses.dataclass
class CommandLine:
    scene: str
    output: str
    options: list  # (option, value, written as --option=value) in order; the last of an option counts
    flags: list

    def argv(self):
        argv = ["render", self.scene, "-o", self.output]
        for option, value, equals in self.options:
            argv += [f"{option}={value}"] if equals else [option, value]
        return argv + self.flags

    def value(self, option):
        values = [v for o, v, _ in self.options if o == option]
        return values[-1] if values else None


@st.composite
def command_lines(draw):
    """`render SCENE -o OUT` with valid values for some of render's options and a hostile one for one or two
    (one bad value at a time reaches further: the first is all the renderer reports); mostly a valid scene
    argument, output name and flags, sometimes hostile ones."""
    options = [(o, draw(VALID_OPTION_VALUES[o]), draw(st.booleans()))
               for o in draw(st.lists(st.sampled_from(NUMERIC_OPTIONS + TEXT_OPTIONS), max_size=3, unique=True))]
    hostile_count = draw(st.sampled_from([1, 1, 1, 0, 2]))
    for option in draw(st.lists(st.sampled_from(NUMERIC_OPTIONS + TEXT_OPTIONS), min_size=hostile_count,
                                max_size=hostile_count)):
        options.insert(draw(st.integers(0, len(options))),
                       (option, draw(hostile_option_values(option)), draw(st.booleans())))
    hostile = draw(st.integers(0, 9)) == 0
    scene = draw(st.sampled_from(["missing.toml", ".", "", "sub", "scene.toml/", "a\nb.toml", "x" * 300 + ".toml",
                                  "Scene.TOML"])) if hostile else "scene.toml"
    hostile = draw(st.integers(0, 4)) == 0
    output = (draw(st.sampled_from(OUTPUT_STEMS)) + draw(st.sampled_from(OUTPUT_EXTENSIONS)) if hostile
              else draw(st.sampled_from(["out.png", "out.exr", "out.hdr", "out.tif", "out.jpg"])))
    flags = draw(st.lists(st.sampled_from(["--no-progress", "--stats-json=stats.json", "--stats-json=sub",
                                           "--stats-json=missing/s.json", "--stats-json=", "--stats-json=taken.png",
                                           "--bogus", "extra.toml", "--no-progress=1"]),
                          max_size=2, unique=True)) if draw(st.integers(0, 3)) == 0 else ["--no-progress"]
    return CommandLine(scene, output, options, flags)


# --- outputs that alias an input ----------------------------------------------------------------------

ALIAS_SPELLINGS = ("as given", "./", "sub/../", "absolute", "symbolic link", "link to a link", "link in sub",
                   "absolute link", "hard link")
LINK_EXTENSIONS = (".png", ".exr", ".hdr", ".tif", ".jpg", ".json", "")


@dataclasses.dataclass(frozen=True)
class AliasingCommand:
    """A command line one of whose outputs names one of the run's inputs (`target`, a role of
    scenes.scenes_with_every_input's: the scene, its texture, mesh or environment map), spelt some way (a
    relative path through ./ or sub/.., an absolute one, or a symbolic or hard link made beforehand, with
    `link_ext`): `render` with -o, --stats-json or both naming it (the other output a fresh file), or `bench`
    with --json naming it."""
    command: str     # render, bench
    aliased: tuple   # the options naming the input: ("-o",), ("--stats-json",), ("-o", "--stats-json"), ("--json",)
    target: str
    spelling: str
    link_ext: str
    equals: bool     # --option=value rather than --option value
    stats_first: bool  # --stats-json before -o (where -o alone names the input: a fresh --stats-json, first)

    def links(self, roles):
        """(link, what it points at, hard) to make in the example's directory before the run."""
        name = roles[self.target]
        link = "link" + self.link_ext
        if self.spelling in ("symbolic link", "absolute link"):
            return [(link, name, False)]
        if self.spelling == "link to a link":
            return [("first" + self.link_ext, name, False), (link, "first" + self.link_ext, False)]
        if self.spelling == "link in sub":
            return [(os.path.join("sub", link), os.path.join("..", name), False)]
        if self.spelling == "hard link":
            return [(link, name, True)]
        return []

    def path(self, roles, directory):
        """The input as the output option names it."""
        name = roles[self.target]
        link = "link" + self.link_ext
        return {"as given": name, "./": "./" + name, "sub/../": "sub/../" + name,
                "absolute": os.path.join(directory, name), "symbolic link": link, "link to a link": link,
                "link in sub": os.path.join("sub", link), "absolute link": os.path.join(directory, link),
                "hard link": link}[self.spelling]

    def argv(self, roles, directory):
        aliased = self.path(roles, directory)
        pairs = [(option, aliased) for option in self.aliased]
        if self.command == "bench":
            head = ["bench", roles["scene"], "--repeat", "1", "--spp", "1"]
        else:
            head = ["render", roles["scene"], "--no-progress", "--spp", "1"]
            if "-o" not in self.aliased:
                pairs.append(("-o", "out.exr"))
            elif self.stats_first:  # a fresh --stats-json beside the -o that aliases
                pairs.append(("--stats-json", "stats.json"))
            if self.stats_first:
                pairs.reverse()
        return head + [a for option, value in pairs
                       for a in ([f"{option}={value}"] if self.equals else [option, value])]


@st.composite
def aliasing_command_lines(draw):
    command = draw(st.sampled_from(["render", "render", "render", "bench"]))
    aliased = ("--json",) if command == "bench" else draw(st.sampled_from([("-o",), ("--stats-json",),
                                                                           ("-o", "--stats-json")]))
    return AliasingCommand(command, aliased, draw(st.sampled_from(["scene", "texture", "mesh", "environment map"])),
                           draw(st.sampled_from(ALIAS_SPELLINGS)), draw(st.sampled_from(LINK_EXTENSIONS)),
                           draw(st.booleans()), draw(st.booleans()))


def parsed_int(text):
    """What argparse's type=int makes of `text`, or None."""
    try:
        return int(text)
    except (TypeError, ValueError):
        return None


# --- the environment -----------------------------------------------------------------------------------

def env_text():
    return st.text(st.characters(blacklist_categories=["Cs"], blacklist_characters="\x00"), max_size=6)


ENVIRONMENT_VALUES = {  # the variables the renderer reads in this process, and values to try
    "RAYTRACE_LANES": ("", "1", "4", "8", "16", "0", "2", "3", "-1", "32", "abc", "8.0", " 8", "٨", "１６",
                       "99999999999999999999", "1e1", "0x8", "8\n"),
    "RAYTRACE_TARGET": ("", "pocl", "x86-64-v2", "x86-64-v3", "x86-64-v4", "x86-64", "x86-64-v5", "generic",
                        "native", "znver3", "skylake-avx512", "X86-64-V3", " x86-64-v3", "x86-64-v3\n"),
    "POCL_CACHE_DIR": ("", "cache", "new/deeper/cache", "scene.toml", "scene.toml/cache", "/dev/null",
                       "/dev/null/cache", "/proc", "/proc/self/cache", "/nonexistent/cache", ".", "a\nb", "é"),
}
# Variables PoCL and the OpenCL loader read once, when a process first lists the platforms: tried in a
# child process.
LOADER_VALUES = {
    "POCL_DEVICES": ("", "pthread", "basic", "cuda", "none", "pthread pthread", "é"),
    "OCL_ICD_VENDORS": ("", "/nonexistent", "/dev/null", "."),
    "OCL_ICD_FILENAMES": ("", "/nonexistent.so", "/dev/null", "libnothing.so"),
}


def environments(values):
    """Some of the variables, each set to one of its values or to random text."""
    return st.dictionaries(st.sampled_from(sorted(values)), st.just(None), min_size=1).flatmap(
        lambda chosen: st.fixed_dictionaries({k: st.one_of(st.sampled_from(values[k]), env_text())
                                              for k in sorted(chosen)}))
