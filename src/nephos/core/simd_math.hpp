#pragma once
// Vector variants of libm's exponentials and log1p: with these declarations a loop that calls
// std::exp, std::expm1 or std::log1p and vectorises calls glibc's libmvec (2, 4 or 8 lanes per
// call, as the target allows) instead of one scalar call per element. glibc declares them only
// under -ffast-math, which nephos does not use. libmvec's exp, expm1 and log1p are within 4 ulp
// (glibc manual, "Known Maximum Errors in Math Functions") and can differ from the scalar
// functions in the last bits: a loop's elements beyond the last whole vector (its scalar
// remainder) may round differently, deterministically. Included by the .cpp files whose batched
// loops want them.
#include <cmath>

#if defined(__x86_64__) && defined(__GLIBC__) && defined(_OPENMP)
extern "C" {
#pragma omp declare simd notinbranch
double exp(double) noexcept;
#pragma omp declare simd notinbranch
double expm1(double) noexcept;
#pragma omp declare simd notinbranch
double log1p(double) noexcept;
}
#endif
