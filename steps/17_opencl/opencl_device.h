// Chapter 17's host side of OpenCL: which devices there are, which one renders, and the program built for it. Shared
// by the chapter and its tests (tests/opencl), which run the same kernels' building blocks on the same device.
#pragma once

#define CL_HPP_TARGET_OPENCL_VERSION 120
#define CL_HPP_MINIMUM_OPENCL_VERSION 120
#define CL_HPP_ENABLE_EXCEPTIONS
#include <CL/opencl.hpp>

#include <string>
#include <vector>

namespace raylife::opencl {

/// One device of one platform, as --list-devices shows it.
struct DeviceInfo {
  cl::Device device;
  std::string platform;        // the platform's name ("Portable Computing Language")
  std::string name;            // the device's
  bool gpu = false;            // CL_DEVICE_TYPE_GPU
  unsigned computeUnits = 0;   // CL_DEVICE_MAX_COMPUTE_UNITS
  unsigned long long memory = 0; // CL_DEVICE_GLOBAL_MEM_SIZE, bytes
  std::string version;         // CL_DEVICE_VERSION
};

/// Every device of every platform, platform by platform: the numbering --device uses. Empty when there is no
/// OpenCL platform (no ICD installed) or none has a device.
std::vector<DeviceInfo> listDevices();

/// The message for a machine without any: what to install.
std::string noDeviceMessage();

/// Device `index` of listDevices() (−1: the first GPU, else the first device). @throws ChapterError (runner.h)
/// when there is none; UsageError for an index past the last.
DeviceInfo chooseDevice(int index);

/// The chapter's kernels' source (blocks.cl, then stages.cl), embedded at build time.
const std::string& kernelSource();
/// The building blocks alone (blocks.cl): what the tests wrap in kernels of their own.
const std::string& blocksSource();

/// Builds `source` for `device` with the driver's options `options` plus $RAYLIFE_OPENCL_OPTIONS (say "-cl-fast-relaxed-math"
/// to try). @throws ChapterError carrying the driver's build log when it does not compile.
cl::Program buildProgram(const cl::Context& context, const cl::Device& device, const std::string& source,
                         const std::string& options = "");

/// "clEnqueueNDRangeKernel failed (CL_OUT_OF_RESOURCES, -5)": a cl::Error, in words.
std::string describe(const cl::Error& e);

} // namespace raylife::opencl
