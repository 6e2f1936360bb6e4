#!/usr/bin/env bash
# Proves the wide-vector kernels cannot leak into the baseline program (the ODR hazard of
# compiling the same inline code with different -m flags): each wide kernel object
# (batch_avx2, batch_avx512) must define exactly one external symbol, its entry point — no weak
# (COMDAT) copy of an inline or template function the linker could pick for the whole program —
# and the baseline objects must contain no AVX instruction (no ymm/zmm register).
# In an optimised build each wide object must also hold wide instructions (its loop vectorised);
# an unoptimised one (the sanitizer build, -O1) does not vectorise, so PORTHOLE_ISA_NO_VECTOR_CHECK=1
# (set by CMake there) skips that one check and keeps the others.
# Usage: isa_symbols_test.sh OBJECT... (the porthole_optics objects, from CMake).
set -euo pipefail
fail=0
checked=0
# Number of instructions using a 256- or 512-bit register in an object.
wide() { objdump -d --no-show-raw-insn "$1" | grep -cE '%[yz]mm[0-9]' || true; }
for obj in "$@"; do
  case "$(basename "$obj")" in
    batch_avx2.cc.o) want='porthole::optics::batch_detail::KernelsAvx2()' ;;
    batch_avx512.cc.o) want='porthole::optics::batch_detail::KernelsAvx512()' ;;
    *)
      if [[ $(wide "$obj") -ne 0 ]]; then
        echo "FAIL: baseline object $obj contains AVX instructions"
        fail=1
      fi
      checked=$((checked + 1))
      continue
      ;;
  esac
  defined=$(nm -C -g --defined-only "$obj" | cut -d' ' -f3-)
  if [[ "$defined" != "$want" ]]; then
    echo "FAIL: $obj must define only $want; it defines:"
    nm -C -g --defined-only "$obj"
    fail=1
  fi
  if [[ -z "${PORTHOLE_ISA_NO_VECTOR_CHECK:-}" && $(wide "$obj") -eq 0 ]]; then
    echo "FAIL: $obj has no wide-vector instruction (its loop did not vectorise)"
    fail=1
  fi
  checked=$((checked + 1))
done
[[ $checked -ge 3 ]] || { echo "FAIL: expected the optics objects, got: $*"; exit 1; }
[[ $fail -eq 0 ]] && echo "ok: $checked objects checked"
exit $fail
