"""Which AVX-512 instructions share the multiply (FMA) pipes with vfmadd: throughput of
pairs of independent 512-bit instructions, in cycles per 8 + 8 (or per 8 alone),
relative to 8 independent vfmadd213ps (one per cycle where a 512-bit FMA issues once per
cycle). 8 means the pair issues side by side; 16, that the second op takes the FMA pipes
too; 17, that it takes them for two cycles per instruction, as vfmadd does for one.

    python3 tools/port_pairs.py

Needs gcc and a CPU with AVX-512F/DQ. Writes and runs a C program in a temporary folder.
"""

import os
import subprocess
import tempfile


def main():
    def r8(op, pre="%%zmm0,%%zmm1,", dst0=2, wrap=8):
        return "".join(f"{op} {pre}%%zmm{dst0 + i % wrap}\\n" for i in range(8))

    fma = r8("vfmadd213ps")
    cmp = "".join(f"vcmpps $5,%%zmm0,%%zmm1,%%k{1 + i % 4}\\n" for i in range(8))

    def second(op):
        return r8(op, dst0=10, wrap=6)

    def second_unary(op, imm=""):
        return r8(op, pre=f"{imm}%%zmm0,", dst0=10, wrap=6)

    tests = {
        "fma": fma,
        "add": r8("vaddps"),
        "scalef": r8("vscalefps"),
        "perm": r8("vpermps"),
        "cmp->k": cmp,
        "fma+add": fma + second("vaddps"),
        "fma+cmp->k": fma + cmp,
        "fma+scalef": fma + second("vscalefps"),
        "fma+perm": fma + second("vpermps"),
        "fma+max": fma + second("vmaxps"),
        "fma+paddd": fma + second("vpaddd"),
        "fma+pandd": fma + second("vpandd"),
        "fma+reduce": fma + second_unary("vreduceps", "$8,"),
        "fma+rndscale": fma + second_unary("vrndscaleps", "$8,"),
        "fma+pslld": fma + second_unary("vpslld", "$23,"),
        "fma+cvtps2dq": fma + second_unary("vcvtps2dq"),
        "fma+getexp": fma + second_unary("vgetexpps"),
        "add+cmp->k": r8("vaddps") + cmp,
        "add+perm": r8("vaddps") + second("vpermps"),
    }
    clobber = ",".join(f'"xmm{i}"' for i in range(16)) + ',"k1","k2","k3","k4"'
    src = [
        "#include <stdio.h>",
        "#include <time.h>",
        "static double now(void){struct timespec t;clock_gettime(CLOCK_MONOTONIC,&t);"
        "return t.tv_sec+t.tv_nsec*1e-9;}",
        "#define N 50000000L",
    ]
    for i, body in enumerate(tests.values()):
        src.append(
            f"static double t{i}(void){{double best=1e9;for(int r=0;r<5;r++){{"
            f"double t0=now();for(long i=0;i<N;i++){{__asm__ volatile(\"{body}\":::{clobber});}}"
            f"double d=(now()-t0)/N;if(d<best)best=d;}}return best;}}"
        )
    src.append("int main(void){double f=t0();")
    for i, name in enumerate(tests):
        src.append(f'printf("%-14s %5.2f\\n","{name}",t{i}()/f*8);')
    src.append("return 0;}")
    with tempfile.TemporaryDirectory() as d:
        c, exe = os.path.join(d, "pairs.c"), os.path.join(d, "pairs")
        with open(c, "w") as f:
            f.write("\n".join(src))
        subprocess.run(["gcc", "-O2", "-mavx512f", "-mavx512dq", "-o", exe, c], check=True)
        subprocess.run([exe], check=True)


if __name__ == "__main__":
    main()
