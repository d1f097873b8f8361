"""The built cores' machine code, read back with objdump: no AVX-512 mask
stored to the stack in 8 or 16 bits and read back as a wider integer.

GCC 12.2 (-O3 -march=native, with LTO) compiled a 16-lane compare's mask into
`kmovw %k0, 0x198(%rsp)` then `mov 0x198(%rsp), %edx`: bits 16-31 came from
stale stack bytes, and a loop over the mask's set bits visited lanes that do
not exist (cpp/simd/lanes.hpp, lane_bits). Which code the compiler spills
that way changes with unrelated edits, so every build is scanned.
"""
from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import pytest

from sphfluid import _core

# kmovb/kmovw from a mask register to a frame slot
STORE = re.compile(r"\bkmov([bw])\s+%k\d,(-?0x[0-9a-f]+\(%r[sb]p\))")
WIDE_DEST = re.compile(r",%(e[a-z]{2}|r[a-z0-9]+d?|r\d+)$")


def _instruction(line: str) -> tuple[str, str]:
    """(mnemonic, operands) of one objdump line."""
    text = line.split("\t")[-1].strip()
    parts = text.split(None, 1)
    return (parts[0], parts[1] if len(parts) > 1 else "") if parts else ("", "")


def narrow_mask_reads(disassembly: str, reach: int = 400) -> list[str]:
    """Each 8- or 16-bit mask store to a frame slot whose next use, within the
    same function, reads the slot as a 32- or 64-bit integer."""
    lines = disassembly.splitlines()
    found = []
    for k, line in enumerate(lines):
        m = STORE.search(line)
        if not m:
            continue
        slot = m.group(2)
        for later in lines[k + 1:k + 1 + reach]:
            if not later.strip() or later.rstrip().endswith(">:"):
                break  # the function ends
            if slot not in later:
                continue
            op, args = _instruction(later)
            reads_first = args.startswith(slot)
            wide = (reads_first and WIDE_DEST.search(args) is not None
                    and not op.startswith(("movz", "movs", "kmov")))
            wide = wide or (op in ("cmpl", "cmpq", "testl", "testq") and slot in args)
            if wide:
                found.append(f"{line.strip()}  ->  {later.strip()}")
            break  # the slot's next use decides
    return found


BAD = """\
  111638:\tkmovw  %k0,0x198(%rsp)
  111641:\tmov    0x198(%rsp),%edx
  111648:\ttest   %edx,%edx
"""


def test_the_scan_finds_a_mask_read_back_wider_than_it_was_stored():
    assert len(narrow_mask_reads(BAD)) == 1  # (the build that visited rows twice)
    tz = "  1:\tkmovw  %k0,0x158(%rsp)\n  2:\ttzcnt  0x158(%rsp),%eax\n"
    assert len(narrow_mask_reads(tz)) == 1
    cmp = "  1:\tkmovb  %k1,-0x20(%rbp)\n  2:\tcmpl   $0x0,-0x20(%rbp)\n"
    assert len(narrow_mask_reads(cmp)) == 1


@pytest.mark.parametrize("ok", [
    "  1:\tkmovw  %k1,0x2b8(%rsp)\n  2:\tkmovw  0x2b8(%rsp),%k1\n",  # a mask's own spill
    "  1:\tkmovw  %k0,0x198(%rsp)\n  2:\tmovzwl 0x198(%rsp),%edx\n",  # zero-extended
    "  1:\tkmovw  %k0,0x198(%rsp)\n  2:\tmov    %eax,0x198(%rsp)\n  3:\tmov    0x198(%rsp),%edx\n",
    "  1:\tkmovw  %k0,0x198(%rsp)\n\n  2:\tmov    0x198(%rsp),%edx\n",  # another function
], ids=["mask spill", "zero-extended", "slot rewritten", "another function"])
def test_the_scan_passes_reads_of_the_stored_width(ok):
    assert narrow_mask_reads(ok) == []


def _cores() -> list[Path]:
    here = Path(_core.__file__).parent
    return sorted({Path(_core.__file__), *here.glob("_core*.so")})


@pytest.mark.skipif(shutil.which("objdump") is None, reason="objdump (binutils) not installed")
@pytest.mark.parametrize("core", _cores(), ids=lambda p: p.name.split(".")[0])
def test_no_core_reads_a_mask_back_wider_than_it_was_stored(core):
    asm = subprocess.run(["objdump", "-d", "--no-show-raw-insn", str(core)], check=True,
                         capture_output=True, text=True).stdout
    assert "kmov" in asm or "avx512" not in core.name, "an AVX-512 core without mask moves"
    bad = narrow_mask_reads(asm)
    assert not bad, f"{len(bad)} mask(s) read back wider than stored in {core.name}:\n" + \
        "\n".join(bad[:5])
