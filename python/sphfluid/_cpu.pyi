# Types of the compiled module sphfluid._cpu (cpp/bind/cpu_module.cpp).
from typing import TypedDict

class _Features(TypedDict):
    avx2: bool  # x86-64-v3: AVX2, FMA, BMI1/2, F16C, LZCNT, MOVBE
    avx512: bool  # x86-64-v4: AVX-512 F, BW, CD, DQ, VL

def features() -> _Features:
    """{'avx2': bool, 'avx512': bool}: whether this CPU runs x86-64-v3 (AVX2, FMA, BMI1/2, F16C, LZCNT, MOVBE) and x86-64-v4 (AVX-512 F, BW, CD, DQ, VL) code."""
