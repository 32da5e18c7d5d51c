#pragma once
// CPU time of the whole process (user + system, all threads, GL driver threads included).
// On a shared machine a stage's wall time depends on the neighbours' load, its CPU time much
// less: reports and benchmarks give both.
namespace vellum {

/// Milliseconds of CPU time the process has used so far.
double processCpuMs();

}  // namespace vellum
