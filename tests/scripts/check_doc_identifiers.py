#!/usr/bin/env python3
"""Every code identifier the docs cite exists in the tree.

Reads README.md and docs/*.md, takes the spans in backticks, and checks three kinds of names
in them against every word of the sources (include/, samples/, tests/, bench/, fuzz/, cmake/,
run.sh, CMakeLists.txt) and every file name of the tree:
  - calls: `name(` (the last part of `a::b::name(`),
  - qualified names: `a::b`,
  - plain identifiers with an underscore: `decode_bsvtf_tile`, `test_vt_cache`.
Generated shader names are cited with their prefix (`P_cache_sample`, `btflod_vt_site`): the
prefix is dropped before the lookup. Names of other projects (Filament, Mesa, the sanitizers,
GLSL) are listed in KNOWN_ELSEWHERE with where they live. Exits 1 and lists each unknown name
with its file and line; prints a count otherwise.
"""
import os
import re
import sys

KNOWN_ELSEWHERE = {
    "Camera::setCustomProjection": "Filament's camera API (docs/filament.md names what btflod does not use)",
    "lp_build_sample_mipmap": "Mesa llvmpipe's texture sampler (docs/demo.md explains its cost)",
    "lp_exec_mask_cond_push": "Mesa llvmpipe's execution mask (docs/demo.md)",
    "need_lerp": "Mesa llvmpipe's sampler (docs/demo.md)",
    "__sanitizer_cov_trace_cmp8": "LLVM's SanitizerCoverage runtime (docs/fuzzing.md)",
    "early_fragment_tests": "a GLSL layout qualifier (docs/shaders.md)",
    "mpi_fmf_check_np2": "the ctest mpi_fmf_check_np${np} of tests/CMakeLists.txt for np = 2",
}
PREFIXES = ("P_", "btflod_")
SOURCE_DIRS = ("include", "samples", "tests", "bench", "fuzz", "cmake")
SOURCE_SUFFIXES = (".hpp", ".cpp", ".inl", ".h", ".cmake", ".txt", ".js", ".sh", ".py", ".html", ".mat", ".in")


def tree_words(root):
    words = set()
    texts = []
    for d in SOURCE_DIRS:
        for dirpath, _, files in os.walk(os.path.join(root, d)):
            for f in files:
                words.add(os.path.splitext(f)[0])
                words.add(f)
                if f.endswith(SOURCE_SUFFIXES):
                    with open(os.path.join(dirpath, f), errors="replace") as fh:
                        texts.append(fh.read())
    for f in ("run.sh", "CMakeLists.txt"):
        p = os.path.join(root, f)
        if os.path.exists(p):
            with open(p, errors="replace") as fh:
                texts.append(fh.read())
    for t in texts:
        words.update(re.findall(r"[A-Za-z_][A-Za-z0-9_]*", t))
    return words


def known(name, words):
    if name in KNOWN_ELSEWHERE:
        return True
    for part in name.split("::"):
        if part == "std" or part in words:
            continue
        if any(part.startswith(p) and part[len(p):] in words for p in PREFIXES):
            continue
        return False
    return True


def self_test():
    """The check fails on a doc citing a name that exists nowhere, passes once it exists."""
    import tempfile
    with tempfile.TemporaryDirectory() as root:
        os.makedirs(os.path.join(root, "docs"))
        os.makedirs(os.path.join(root, "include"))
        with open(os.path.join(root, "README.md"), "w") as f:
            f.write("Call `present_function()` and `ns::present_type`.\n")
        with open(os.path.join(root, "docs", "a.md"), "w") as f:
            f.write("See `wrap_tile_borders(tile)` and `P_present_function`.\n")
        with open(os.path.join(root, "include", "a.hpp"), "w") as f:
            f.write("namespace ns { struct present_type; void present_function(); }\n")
        if check(root) != 1:
            print("self-test: a missing name was not reported")
            return 1
        with open(os.path.join(root, "include", "b.hpp"), "w") as f:
            f.write("void wrap_tile_borders(int);\n")
        if check(root) != 0:
            print("self-test: an existing name was reported")
            return 1
    print("self-test passed")
    return 0


def main():
    if len(sys.argv) > 1 and sys.argv[1] == "--self-test":
        return self_test()
    return check(sys.argv[1] if len(sys.argv) > 1 else ".")


def check(root):
    docs = [os.path.join(root, "README.md")]
    docs += sorted(os.path.join(root, "docs", f) for f in os.listdir(os.path.join(root, "docs")) if f.endswith(".md"))
    words = tree_words(root)
    unknown = []
    cited = 0
    for doc in docs:
        with open(doc, errors="replace") as fh:
            for line_no, line in enumerate(fh, 1):
                for code in re.findall(r"`([^`]+)`", line):
                    names = re.findall(r"([A-Za-z_][A-Za-z0-9_]*(?:::[A-Za-z_][A-Za-z0-9_]*)*)\(", code)
                    names += re.findall(r"\b([A-Za-z_][A-Za-z0-9_]*(?:::[A-Za-z_][A-Za-z0-9_]*)+)\b", code)
                    if re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*_[A-Za-z0-9_]*", code):
                        names.append(code)
                    for name in dict.fromkeys(names):
                        cited += 1
                        if not known(name, words):
                            unknown.append(f"{os.path.relpath(doc, root)}:{line_no}: `{name}` names nothing in the tree")
    if unknown:
        print("\n".join(unknown))
        print(f"{len(unknown)} of {cited} cited names exist nowhere in the sources (fix the doc, or list a name of "
              "another project in KNOWN_ELSEWHERE with where it lives)")
        return 1
    print(f"doc identifiers: all {cited} cited names exist")
    return 0


if __name__ == "__main__":
    sys.exit(main())
