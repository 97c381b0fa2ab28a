#!/usr/bin/env python3
"""Mutation fuzzing of the bundled scenes through the CLI (issue 16: no input breaks a run).

Each case copies scenes/ to a temporary folder, mutates one file (numbers replaced by
extremes such as nan, inf, 3.4e38, -0 or 2^32; lines dropped or duplicated; keys renamed;
bytes flipped) and runs `radsplat render` (static scenes, OBJ and MTL files) or
`radsplat animate` (animated scenes) at 8x8. A case is bad when radsplat panics, dies by a
signal, times out, fails but leaves an output behind, or succeeds without writing one.
Bad inputs are copied to the output folder.

    benches/robustness/fuzz_scenes.py [--seed S] [--cases N] [--kind scenes|meshes]
"""
import argparse, os, random, re, shutil, subprocess, sys, tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
EXTREMES = ["0", "-0", "1e38", "-1e38", "3.4e38", "nan", "inf", "-1", "1e-45", "0.0",
            "1e20", "65536", "4294967296", "-2147483648", '"x"', "[]", "[0,0,0]",
            "[1e38,1e38,1e38]"]
SCENES = ["cornell-box.toml", "cube-in-box-anim.toml", "moving-light.toml", "spheres.toml",
          "cornell-box-glossy.toml", "env-sphere.toml", "nave.toml", "spheres-glossy.toml"]
# Scenes rendered as still frames (`render`); the others are animated (`animate`).
STILL = {"cornell-box.toml", "cornell-box-glossy.toml", "env-sphere.toml", "nave.toml"}
MESHES = {"cube.obj": "cube-in-box.toml", "room.obj": "cube-in-box.toml",
          "cornell-box.obj": "cornell-box.toml", "cornell-box.mtl": "cornell-box.toml",
          "cornell-box-glossy.mtl": "cornell-box-glossy.toml", "nave.obj": "nave.toml",
          "nave.mtl": "nave.toml", "glossy-sphere.mtl": "env-sphere.toml",
          "sky.hdr": "env-sphere.toml"}


def mutate(lines, rng):
    for _ in range(rng.randint(1, 3)):
        kind, j = rng.random(), rng.randrange(len(lines))
        if kind < 0.55:
            nums = list(re.finditer(r"-?\d+(\.\d+)?(e-?\d+)?", lines[j]))
            if nums:
                m = rng.choice(nums)
                lines[j] = lines[j][:m.start()] + rng.choice(EXTREMES) + lines[j][m.end():]
        elif kind < 0.7:
            del lines[j]
        elif kind < 0.8:
            lines.insert(j, lines[j])
        elif kind < 0.9:
            lines[j] = lines[j].replace("=", "_x =", 1)
        elif lines[j]:
            b = bytearray(lines[j].encode("latin-1"))
            b[rng.randrange(len(b))] = rng.randrange(256)
            lines[j] = b.decode("latin-1")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--cases", type=int, default=200)
    ap.add_argument("--kind", choices=["scenes", "meshes"], default="scenes")
    ap.add_argument("--bin", default=os.path.join(ROOT, "target", "release", "radsplat"))
    ap.add_argument("--out", default=tempfile.mkdtemp(prefix="radsplat-fuzz-"))
    a = ap.parse_args()
    rng = random.Random(a.seed)
    bad, rendered = 0, 0
    work = os.path.join(a.out, "work")
    for i in range(a.cases):
        shutil.rmtree(work, ignore_errors=True)
        shutil.copytree(os.path.join(ROOT, "scenes"), work)
        base = rng.choice(SCENES if a.kind == "scenes" else list(MESHES))
        path = os.path.join(work, base)
        lines = open(path, encoding="latin-1").read().split("\n")
        mutate(lines, rng)
        open(path, "w", encoding="latin-1").write("\n".join(lines))
        scene = path if a.kind == "scenes" else os.path.join(work, MESHES[base])
        out = os.path.join(work, "out")
        os.makedirs(out)
        common = ["--size", "8x8", "--plane-resolution", "8", "--quiet"]
        if a.kind == "scenes" and base not in STILL:
            frames = rng.choice(["0..2", "5..6", "0..0"])
            cmd = [a.bin, "animate", scene, "--frames", frames, "-o", out + "/f_####.exr"]
        else:
            cmd = [a.bin, "render", scene, "-o", out + "/o.exr", "--png", out + "/o.png"]
        try:
            r = subprocess.run(cmd + common, capture_output=True, timeout=120)
        except subprocess.TimeoutExpired:
            bad += 1
            print(f"case {i} ({base}): timeout", flush=True)
            shutil.copy(path, os.path.join(a.out, f"bad_{i}_{base}"))
            continue
        err = r.stderr.decode("latin-1")
        left = os.listdir(out)
        rendered += r.returncode == 0
        if (r.returncode < 0 or "panicked" in err or (r.returncode != 0 and left)
                or (r.returncode == 0 and not left)):
            bad += 1
            shutil.copy(path, os.path.join(a.out, f"bad_{i}_{base}"))
            print(f"case {i} ({base}): exit {r.returncode}, left {left}: {err[-300:]}",
                  flush=True)
    print(f"{a.cases} cases ({a.kind}, seed {a.seed}): {bad} bad, {rendered} rendered; "
          f"bad inputs in {a.out}")
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()
