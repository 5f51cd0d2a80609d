// A function of a system compiled at run time from the user's expressions
// (python/raydamp/systems/system/compile.py: SymEngine's LLVM JIT). Its C signature is
// void f(double* out, const double* in, void* data); the caller keeps the compiled
// code alive as long as any model holds the pointer.
#pragma once

namespace raydamp {

struct CompiledFunction {
  using Fn = void (*)(double* out, const double* in, void* data);
  Fn fn = nullptr;
  void* data = nullptr;

  void operator()(double* out, const double* in) const { fn(out, in, data); }
  explicit operator bool() const { return fn != nullptr; }
};

}  // namespace raydamp
