#include "opencl_device.h"

#include "opencl_kernels.h" // generated at build time from blocks.cl and stages.cl (cmake/EmbedText.cmake)
#include "render/options.h"
#include "render/runner.h"

#include <cstdlib>

namespace raylife::opencl {

std::vector<DeviceInfo> listDevices()
{
  std::vector<DeviceInfo> devices;
  std::vector<cl::Platform> platforms;
  try {
    cl::Platform::get(&platforms);
  } catch (const cl::Error&) {
    return devices; // no ICD, or an ICD loader with no platform (CL_PLATFORM_NOT_FOUND_KHR)
  }
  for (const cl::Platform& platform : platforms) {
    std::vector<cl::Device> found;
    try {
      platform.getDevices(CL_DEVICE_TYPE_ALL, &found);
    } catch (const cl::Error&) {
      continue; // a platform without devices
    }
    for (const cl::Device& d : found)
      devices.push_back(DeviceInfo{d, platform.getInfo<CL_PLATFORM_NAME>(), d.getInfo<CL_DEVICE_NAME>(),
                                   (d.getInfo<CL_DEVICE_TYPE>() & CL_DEVICE_TYPE_GPU) != 0,
                                   d.getInfo<CL_DEVICE_MAX_COMPUTE_UNITS>(), d.getInfo<CL_DEVICE_GLOBAL_MEM_SIZE>(),
                                   d.getInfo<CL_DEVICE_VERSION>()});
  }
  return devices;
}

std::string noDeviceMessage()
{
  return "no OpenCL device: no platform is installed, or none has a device (install PoCL's CPU device with "
         "./setup.sh --opencl, or a GPU's OpenCL driver; --list-devices shows what there is)";
}

DeviceInfo chooseDevice(int index)
{
  const std::vector<DeviceInfo> devices = listDevices();
  if (devices.empty())
    throw ChapterError(noDeviceMessage());
  if (index >= int(devices.size()))
    throw UsageError("--device " + std::to_string(index) + ": there " +
                     (devices.size() == 1 ? std::string("is one device (0)")
                                          : "are " + std::to_string(devices.size()) + " devices (0 to " +
                                                std::to_string(devices.size() - 1) + ")") +
                     "; --list-devices shows them");
  if (index >= 0)
    return devices[std::size_t(index)];
  for (const DeviceInfo& d : devices)
    if (d.gpu)
      return d;
  return devices.front();
}

const std::string& kernelSource()
{
  static const std::string source = std::string(kBlocksCl) + "\n" + kStagesCl;
  return source;
}

const std::string& blocksSource()
{
  static const std::string source = kBlocksCl;
  return source;
}

cl::Program buildProgram(const cl::Context& context, const cl::Device& device, const std::string& source,
                         const std::string& options)
{
  std::string all = "-cl-std=CL1.2 " + options;
  if (const char* extra = std::getenv("RAYLIFE_OPENCL_OPTIONS"))
    all += std::string(" ") + extra;
  cl::Program program(context, source);
  try {
    program.build(std::vector<cl::Device>{device}, all.c_str());
  } catch (const cl::Error& e) {
    std::string log;
    try {
      log = program.getBuildInfo<CL_PROGRAM_BUILD_LOG>(device);
    } catch (const cl::Error&) {
      log = "(the driver gave no build log)";
    }
    while (!log.empty() && (log.back() == '\n' || log.back() == ' ' || log.back() == '\0'))
      log.pop_back();
    throw ChapterError("the kernels did not build on " + device.getInfo<CL_DEVICE_NAME>() + " (" + describe(e) +
                       ", options \"" + all + "\"); the driver's build log:\n" + log);
  }
  return program;
}

std::string describe(const cl::Error& e)
{
  return std::string(e.what()) + " failed (error " + std::to_string(e.err()) + ")";
}

} // namespace raylife::opencl
