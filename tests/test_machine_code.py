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

from sphfluid import _core, _cpu

# kmovb/kmovw from a mask register to a frame slot (its width in bits)
STORE = re.compile(r"\bkmov([bw])\s+%k\d,((?:-?0x[0-9a-f]+)?\(%r[sb]p\))")
WIDTH = {"b": 8, "w": 16, "d": 32, "q": 64}
LINE = re.compile(r"^\s*[0-9a-f]+:\s+(\S+)\s*(.*)$")
# general registers by width
REG64 = re.compile(r"^%r(ax|bx|cx|dx|si|di|bp|sp|8|9|1[0-5])$")
REG32 = re.compile(r"^%(e(ax|bx|cx|dx|si|di|bp|sp)|r(8|9|1[0-5])d)$")
REG16 = re.compile(r"^%((ax|bx|cx|dx|si|di|bp|sp)|r(8|9|1[0-5])w)$")
NO_READ = ("lea", "nop", "prefetch")


def _parse(line: str) -> tuple[str, list[str]]:
    """(mnemonic, operands) of one objdump line; ("", []) for anything else."""
    m = LINE.match(line.split("#")[0].split("<")[0])
    if not m:
        return "", []
    return m.group(1), [a.strip() for a in re.split(r",(?![^(]*\))", m.group(2)) if a.strip()]


def _width(reg: str) -> int:
    return 64 if REG64.match(reg) else 32 if REG32.match(reg) else 16 if REG16.match(reg) else 8


def _read_width(op: str, args: list[str], slot: str) -> int:
    """How many bits of the slot an instruction reads (0: none; it is written)."""
    if op.startswith(NO_READ):
        return 0
    if op.startswith("kmov"):
        return WIDTH[op[4]] if args and args[0] == slot else 0
    if op.startswith(("movzb", "movsb")):
        return 8
    if op.startswith(("movzw", "movsw")):
        return 16
    regs = [a for a in args if a.startswith("%")]
    if args and args[0] == slot:  # a load, or an operation reading it
        return _width(regs[-1]) if regs else WIDTH.get(op[-1], 32)
    if op.startswith("mov"):  # the slot written over
        return 0
    # the slot as the second operand of cmp, test, and, or, add ...: read at the width
    # of the other operand
    return _width(regs[0]) if regs else WIDTH.get(op[-1], 32)


def narrow_mask_reads(disassembly: str, reach: int = 400) -> list[str]:
    """Each 8- or 16-bit mask store to a frame slot whose next use (within
    `reach` lines of the listing, up to a function's end) reads the slot wider
    than it was stored, unless the value is masked back to the stored width at
    once (`and $0xffff` on the register it was loaded into)."""
    lines = disassembly.splitlines()
    found = []
    for k, line in enumerate(lines):
        m = STORE.search(line)
        if not m:
            continue
        stored, slot = WIDTH[m.group(1)], m.group(2)
        for j in range(k + 1, min(k + 1 + reach, len(lines))):
            later = lines[j]
            if not later.strip() or later.rstrip().endswith(">:"):
                break  # the function ends
            op, args = _parse(later)
            if slot not in args:
                continue
            read = _read_width(op, args, slot)
            if read > stored:
                nxt_op, nxt_args = _parse(lines[j + 1]) if j + 1 < len(lines) else ("", [])
                mask = f"$0x{(1 << stored) - 1:x}"
                masked = (nxt_op.startswith("and") and nxt_args[:1] == [mask]
                          and nxt_args[-1:] == args[-1:])
                if not masked:
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
    for bad in ("  1:\tkmovb  %k1,(%rsp)\n  2:\tmovzwl (%rsp),%eax\n",  # 16 of 8 bits
                "  1:\tkmovw  %k1,0x10(%rsp)\n  2:\tcmp    %eax,0x10(%rsp)\n",
                "  1:\tkmovw  %k1,0x10(%rsp)\n  2:\tkmovd  0x10(%rsp),%k2\n",
                "  1:\tkmovb  %k1,0x10(%rsp)\n  2:\tmov    0x10(%rsp),%ax\n"):
        assert len(narrow_mask_reads(bad)) == 1, bad


@pytest.mark.parametrize("ok", [
    "  1:\tkmovw  %k1,0x2b8(%rsp)\n  2:\tkmovw  0x2b8(%rsp),%k1\n",  # a mask's own spill
    "  1:\tkmovw  %k0,0x198(%rsp)\n  2:\tmovzwl 0x198(%rsp),%edx\n",  # zero-extended
    "  1:\tkmovw  %k0,0x198(%rsp)\n  2:\tmov    %eax,0x198(%rsp)\n  3:\tmov    0x198(%rsp),%edx\n",
    "  1:\tkmovw  %k0,0x198(%rsp)\n\n  2:\tmov    0x198(%rsp),%edx\n",  # another function
    "  1:\tkmovw  %k0,0x198(%rsp)\n  2:\tlea    0x198(%rsp),%rax\n",  # an address only
    "  1:\tkmovw  %k0,0x198(%rsp)\n  2:\tmov    0x198(%rsp),%r8w\n",  # 16 bits
    "  1:\tkmovw  %k0,0x198(%rsp)\n  2:\tmov    0x198(%rsp),%edx\n"
    "  3:\tand    $0xffff,%edx\n",  # masked at once
    "  1:\tkmovw  %k0,0x198(%rsp)\n  2:\tmov    -0x198(%rsp),%edx\n",  # another slot
], ids=["mask spill", "zero-extended", "slot rewritten", "another function", "lea",
        "16-bit register", "masked", "another slot"])
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
    avx512 = "avx512" in core.name or (
        "_core_" not in core.name and _core.build_info["march_native"]
        and _cpu.features()["avx512"])  # a native core built on an AVX-512 CPU
    assert "kmov" in asm or not avx512, "an AVX-512 core without mask moves: nothing scanned"
    bad = narrow_mask_reads(asm)
    assert not bad, f"{len(bad)} mask(s) read back wider than stored in {core.name}:\n" + \
        "\n".join(bad[:5])
