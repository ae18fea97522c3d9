# MAPTUNE_HOST_HAS_AVX2: the compiler takes -mavx2 -mfma and the build machine runs the result;
# MAPTUNE_HOST_HAS_AVX512: the same for -mavx512f.
# The same check (and cache variable) as libs/matcher's descriptor GEMM, shared so that every
# library that compiles a hot file with AVX2/FMA decides the same way; the check runs once.
include_guard(GLOBAL)
include(CheckCXXSourceRuns)
set(CMAKE_REQUIRED_FLAGS "-mavx2 -mfma")
check_cxx_source_runs([=[
#include <immintrin.h>
int main() {
  if (!__builtin_cpu_supports("avx2") || !__builtin_cpu_supports("fma")) return 1;
  volatile float x = 1.5f;
  __m256 a = _mm256_set1_ps(x);
  __m256 r = _mm256_fmadd_ps(a, a, a);
  return _mm256_cvtss_f32(r) == 3.75f ? 0 : 1;
}]=] MAPTUNE_HOST_HAS_AVX2)
unset(CMAKE_REQUIRED_FLAGS)
set(CMAKE_REQUIRED_FLAGS "-mavx512f")
check_cxx_source_runs([=[
#include <immintrin.h>
int main() {
  if (!__builtin_cpu_supports("avx512f")) return 1;
  volatile double x = 1.5;
  __m512d a = _mm512_set1_pd(x);
  __m512d r = _mm512_fmadd_pd(a, a, a);
  return _mm512_cvtsd_f64(r) == 3.75 ? 0 : 1;
}]=] MAPTUNE_HOST_HAS_AVX512)
unset(CMAKE_REQUIRED_FLAGS)
