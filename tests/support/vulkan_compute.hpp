// A small headless Vulkan compute harness for the shader tests: uploads one RGBA texture (2D or 3D),
// binds it with a linear, clamp-to-edge, no-mip sampler, runs a compute shader over a buffer of
// vec4 inputs and returns one float per input. It prefers a CPU device (Mesa lavapipe), pointing the
// loader at lavapipe's ICD when VK_ICD_FILENAMES is unset. Header-only; compiled only when CMake found
// Vulkan (MICROSHADOW_HAVE_VULKAN).
#pragma once

#include <string>
#include <vector>
#include <cstdint>

namespace ms::testing {

struct ComputeTexture {
    std::uint32_t width = 0, height = 0, depth = 1;  // depth 1 with three_d false: a 2D texture
    bool three_d = true;
    std::uint32_t vk_format = 0;                      // VkFormat value
    std::vector<std::uint8_t> texels;                 // tightly packed, x fastest, then y, then z
};

struct ComputeResult {
    std::string skip;             // non-empty: no usable device/format (the reason)
    std::string device;           // the device that ran it
    std::vector<float> values;
};

// The one level of a KTX2 file as a texture (the header fields are checked in lut_formats_test).
inline ComputeTexture ktx2_texture(const std::string& path);

// separate_sampler: bindings are 0 = sampled image, 1 = sampler, 2 = inputs, 3 = outputs (HLSL's
// Texture + SamplerState); otherwise 0 = combined image sampler, 1 = inputs, 2 = outputs (GLSL).
// The shader's local size must divide 64; inputs are padded to a multiple of 64.
ComputeResult run_compute(const std::vector<std::uint32_t>& spirv, const ComputeTexture& texture,
                          const std::vector<float>& inputs_vec4, bool separate_sampler);

// Several textures in one shader (the combined-shader tests): texture k at binding k (combined image
// sampler) or at 2k (image) and 2k + 1 (sampler) when separate_sampler, then the inputs and the
// outputs; the shader writes `outputs_per_input` floats per input (input i's at i * outputs_per_input).
ComputeResult run_compute(const std::vector<std::uint32_t>& spirv, const std::vector<ComputeTexture>& textures,
                          const std::vector<float>& inputs_vec4, bool separate_sampler, std::uint32_t outputs_per_input);

}  // namespace ms::testing

#include <algorithm>
#include <fstream>
#include <iterator>

namespace ms::testing {

inline ComputeTexture ktx2_texture(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    std::vector<std::uint8_t> b{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
    auto u32 = [&](std::size_t at) {
        return std::uint32_t(b.at(at)) | std::uint32_t(b.at(at + 1)) << 8 | std::uint32_t(b.at(at + 2)) << 16 | std::uint32_t(b.at(at + 3)) << 24;
    };
    ComputeTexture t;
    t.vk_format = u32(12);
    t.width = u32(20);
    t.height = u32(24);
    t.depth = std::max(1u, u32(28));
    t.three_d = u32(28) > 0;
    const std::size_t offset = u32(80), length = u32(88);
    t.texels.assign(b.begin() + offset, b.begin() + offset + length);
    return t;
}

}  // namespace ms::testing

#ifdef MICROSHADOW_HAVE_VULKAN
#include <dlfcn.h>
#include <vulkan/vulkan.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "sanitizers.hpp"

namespace ms::testing {

namespace vkh {

inline void check(VkResult r, const char* what) {
    if (r != VK_SUCCESS) throw std::runtime_error(std::string(what) + " failed: VkResult " + std::to_string(int(r)));
}

// Runs cleanups in reverse order of registration, whatever happens.
struct Cleanup {
    std::vector<std::function<void()>> steps;
    ~Cleanup() {
        for (auto it = steps.rbegin(); it != steps.rend(); ++it) (*it)();
    }
    void add(std::function<void()> f) { steps.push_back(std::move(f)); }
};

// Under LeakSanitizer: keeps the drivers of VK_ICD_FILENAMES loaded for the process's lifetime. The
// loader unloads a driver when its instance is destroyed; lavapipe's process-lifetime allocations are
// then referenced only from unmapped static data, and LeakSanitizer reports them as leaks of an
// "<unknown module>" that no suppression can name. Mapped, they stay reachable and nothing is reported.
inline void keep_drivers_loaded() {
    if (!kAsan) return;
    static const bool done = [] {
        const char* list = std::getenv("VK_ICD_FILENAMES");
        std::string files = list ? list : "";
        for (std::size_t start = 0; start < files.size();) {
            const std::size_t end = std::min(files.find(':', start), files.size());
            std::ifstream in(files.substr(start, end - start));
            const auto manifest = nlohmann::json::parse(in, nullptr, false);
            const auto icd = manifest.is_object() ? manifest.find("ICD") : manifest.end();
            if (icd != manifest.end() && icd->is_object()) {
                const auto path = icd->find("library_path");
                if (path != icd->end() && path->is_string())
                    dlopen(path->get<std::string>().c_str(), RTLD_NOW | RTLD_NODELETE);
            }
            start = end + 1;
        }
        return true;
    }();
    (void)done;
}

inline std::uint32_t memory_type(VkPhysicalDevice pd, std::uint32_t bits, VkMemoryPropertyFlags want) {
    VkPhysicalDeviceMemoryProperties mp;
    vkGetPhysicalDeviceMemoryProperties(pd, &mp);
    for (std::uint32_t i = 0; i < mp.memoryTypeCount; ++i)
        if ((bits & (1u << i)) && (mp.memoryTypes[i].propertyFlags & want) == want) return i;
    throw std::runtime_error("no suitable Vulkan memory type");
}

}  // namespace vkh

inline ComputeResult run_compute(const std::vector<std::uint32_t>& spirv, const std::vector<ComputeTexture>& textures,
                                 const std::vector<float>& inputs_vec4, bool separate_sampler, std::uint32_t outputs_per_input) {
    using namespace vkh;
    ComputeResult result;
    // The loader reads VK_ICD_FILENAMES when the instance is created: point it at lavapipe unless the
    // caller chose a driver.
    const char* lvp = "/usr/share/vulkan/icd.d/lvp_icd.x86_64.json";
    if (!std::getenv("VK_ICD_FILENAMES") && std::filesystem::exists(lvp)) setenv("VK_ICD_FILENAMES", lvp, 0);
    keep_drivers_loaded();
    // lavapipe filters 8-bit textures in 8-bit fixed point by default (weights and result rounded to
    // 1/255, up to about one step off exact trilinear filtering); this asks for its float path, so the
    // tests measure the LUT and the shader, not that shortcut. Read once, when lavapipe initialises.
    if (!std::getenv("GALLIVM_PERF")) setenv("GALLIVM_PERF", "no_aos_sampling", 0);
    Cleanup c;

    VkApplicationInfo app{VK_STRUCTURE_TYPE_APPLICATION_INFO};
    app.pApplicationName = "microshadow_tests";
    app.apiVersion = VK_API_VERSION_1_0;
    VkInstanceCreateInfo ici{VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO};
    ici.pApplicationInfo = &app;
    VkInstance instance;
    if (vkCreateInstance(&ici, nullptr, &instance) != VK_SUCCESS) {
        result.skip = "no Vulkan instance (install mesa-vulkan-drivers for lavapipe)";
        return result;
    }
    c.add([=] { vkDestroyInstance(instance, nullptr); });
    std::uint32_t n = 0;
    vkEnumeratePhysicalDevices(instance, &n, nullptr);
    std::vector<VkPhysicalDevice> pds(n);
    vkEnumeratePhysicalDevices(instance, &n, pds.data());
    VkPhysicalDevice pd = VK_NULL_HANDLE;
    std::uint32_t family = 0;
    for (auto d : pds) {
        VkPhysicalDeviceProperties p;
        vkGetPhysicalDeviceProperties(d, &p);
        std::uint32_t nq = 0;
        vkGetPhysicalDeviceQueueFamilyProperties(d, &nq, nullptr);
        std::vector<VkQueueFamilyProperties> qs(nq);
        vkGetPhysicalDeviceQueueFamilyProperties(d, &nq, qs.data());
        for (std::uint32_t q = 0; q < nq; ++q)
            if (qs[q].queueFlags & VK_QUEUE_COMPUTE_BIT) {
                // Prefer the CPU device (lavapipe): the tests' figures are for it.
                if (pd == VK_NULL_HANDLE || p.deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU) {
                    pd = d;
                    family = q;
                    result.device = p.deviceName;
                }
                break;
            }
    }
    if (pd == VK_NULL_HANDLE) {
        result.skip = "no Vulkan device with a compute queue (install mesa-vulkan-drivers for lavapipe)";
        return result;
    }
    for (const auto& tex : textures) {
        VkFormatProperties fp;
        vkGetPhysicalDeviceFormatProperties(pd, VkFormat(tex.vk_format), &fp);
        const VkFormatFeatureFlags need = VK_FORMAT_FEATURE_SAMPLED_IMAGE_BIT | VK_FORMAT_FEATURE_SAMPLED_IMAGE_FILTER_LINEAR_BIT |
                                          VK_FORMAT_FEATURE_TRANSFER_DST_BIT;
        if ((fp.optimalTilingFeatures & need) != need) {
            result.skip = result.device + " cannot linearly filter VkFormat " + std::to_string(tex.vk_format);
            return result;
        }
    }

    const float priority = 1.0f;
    VkDeviceQueueCreateInfo qci{VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO};
    qci.queueFamilyIndex = family;
    qci.queueCount = 1;
    qci.pQueuePriorities = &priority;
    VkDeviceCreateInfo dci{VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO};
    dci.queueCreateInfoCount = 1;
    dci.pQueueCreateInfos = &qci;
    VkDevice dev;
    check(vkCreateDevice(pd, &dci, nullptr, &dev), "vkCreateDevice");
    c.add([=] { vkDestroyDevice(dev, nullptr); });
    VkQueue queue;
    vkGetDeviceQueue(dev, family, 0, &queue);

    // Host-visible buffers: staging (texels), inputs, outputs.
    auto make_buffer = [&](VkDeviceSize size, VkBufferUsageFlags usage, void** mapped) {
        VkBufferCreateInfo bci{VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
        bci.size = size;
        bci.usage = usage;
        bci.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
        VkBuffer buf;
        check(vkCreateBuffer(dev, &bci, nullptr, &buf), "vkCreateBuffer");
        c.add([=] { vkDestroyBuffer(dev, buf, nullptr); });
        VkMemoryRequirements mr;
        vkGetBufferMemoryRequirements(dev, buf, &mr);
        VkMemoryAllocateInfo mai{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
        mai.allocationSize = mr.size;
        mai.memoryTypeIndex = memory_type(pd, mr.memoryTypeBits, VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT);
        VkDeviceMemory mem;
        check(vkAllocateMemory(dev, &mai, nullptr, &mem), "vkAllocateMemory");
        c.add([=] { vkFreeMemory(dev, mem, nullptr); });
        check(vkBindBufferMemory(dev, buf, mem, 0), "vkBindBufferMemory");
        check(vkMapMemory(dev, mem, 0, size, 0, mapped), "vkMapMemory");
        return buf;
    };
    const std::size_t count = inputs_vec4.size() / 4, padded = (count + 63) / 64 * 64;
    void *in_map, *out_map;
    VkBuffer in_buf = make_buffer(padded * 16, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, &in_map);
    std::memset(in_map, 0, padded * 16);
    std::memcpy(in_map, inputs_vec4.data(), inputs_vec4.size() * sizeof(float));
    VkBuffer out_buf = make_buffer(padded * 4 * outputs_per_input, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, &out_map);

    // The sampler engines must use for the LUT: linear, clamp-to-edge, level 0 only.
    VkSamplerCreateInfo sci{VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO};
    sci.magFilter = sci.minFilter = VK_FILTER_LINEAR;
    sci.mipmapMode = VK_SAMPLER_MIPMAP_MODE_NEAREST;
    sci.addressModeU = sci.addressModeV = sci.addressModeW = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
    sci.minLod = sci.maxLod = 0.0f;
    VkSampler sampler;
    check(vkCreateSampler(dev, &sci, nullptr, &sampler), "vkCreateSampler");
    c.add([=] { vkDestroySampler(dev, sampler, nullptr); });

    // The textures: one level each, optimal tiling, device memory, uploaded from a staging buffer.
    struct Uploaded {
        VkBuffer staging;
        VkImage image;
        VkExtent3D extent;
        VkDescriptorImageInfo info;
    };
    std::vector<Uploaded> uploaded;
    for (const auto& tex : textures) {
        const VkFormat format = VkFormat(tex.vk_format);
        void* staging_map;
        VkBuffer staging = make_buffer(tex.texels.size(), VK_BUFFER_USAGE_TRANSFER_SRC_BIT, &staging_map);
        std::memcpy(staging_map, tex.texels.data(), tex.texels.size());
        VkImageCreateInfo ii{VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO};
        ii.imageType = tex.three_d ? VK_IMAGE_TYPE_3D : VK_IMAGE_TYPE_2D;
        ii.format = format;
        ii.extent = {tex.width, tex.height, tex.three_d ? tex.depth : 1u};
        ii.mipLevels = 1;
        ii.arrayLayers = 1;
        ii.samples = VK_SAMPLE_COUNT_1_BIT;
        ii.tiling = VK_IMAGE_TILING_OPTIMAL;
        ii.usage = VK_IMAGE_USAGE_TRANSFER_DST_BIT | VK_IMAGE_USAGE_SAMPLED_BIT;
        ii.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
        VkImage image;
        check(vkCreateImage(dev, &ii, nullptr, &image), "vkCreateImage");
        c.add([=] { vkDestroyImage(dev, image, nullptr); });
        VkMemoryRequirements imr;
        vkGetImageMemoryRequirements(dev, image, &imr);
        VkMemoryAllocateInfo imai{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
        imai.allocationSize = imr.size;
        imai.memoryTypeIndex = memory_type(pd, imr.memoryTypeBits, 0);
        VkDeviceMemory image_mem;
        check(vkAllocateMemory(dev, &imai, nullptr, &image_mem), "vkAllocateMemory(image)");
        c.add([=] { vkFreeMemory(dev, image_mem, nullptr); });
        check(vkBindImageMemory(dev, image, image_mem, 0), "vkBindImageMemory");
        VkImageViewCreateInfo vci{VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO};
        vci.image = image;
        vci.viewType = tex.three_d ? VK_IMAGE_VIEW_TYPE_3D : VK_IMAGE_VIEW_TYPE_2D;
        vci.format = format;
        vci.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
        VkImageView view;
        check(vkCreateImageView(dev, &vci, nullptr, &view), "vkCreateImageView");
        c.add([=] { vkDestroyImageView(dev, view, nullptr); });
        uploaded.push_back({staging, image, ii.extent, {sampler, view, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL}});
    }

    // Descriptors.
    std::vector<VkDescriptorSetLayoutBinding> bindings;
    auto bind = [&](std::uint32_t b, VkDescriptorType t) {
        VkDescriptorSetLayoutBinding x{};
        x.binding = b;
        x.descriptorType = t;
        x.descriptorCount = 1;
        x.stageFlags = VK_SHADER_STAGE_COMPUTE_BIT;
        bindings.push_back(x);
    };
    const std::uint32_t k = std::uint32_t(textures.size());
    const std::uint32_t in_binding = separate_sampler ? 2 * k : k, out_binding = in_binding + 1;
    for (std::uint32_t t = 0; t < k; ++t) {
        if (separate_sampler) {
            bind(2 * t, VK_DESCRIPTOR_TYPE_SAMPLED_IMAGE);
            bind(2 * t + 1, VK_DESCRIPTOR_TYPE_SAMPLER);
        } else {
            bind(t, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER);
        }
    }
    bind(in_binding, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER);
    bind(out_binding, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER);
    VkDescriptorSetLayoutCreateInfo dlci{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
    dlci.bindingCount = std::uint32_t(bindings.size());
    dlci.pBindings = bindings.data();
    VkDescriptorSetLayout dsl;
    check(vkCreateDescriptorSetLayout(dev, &dlci, nullptr, &dsl), "vkCreateDescriptorSetLayout");
    c.add([=] { vkDestroyDescriptorSetLayout(dev, dsl, nullptr); });
    std::vector<VkDescriptorPoolSize> sizes;
    for (const auto& b : bindings) sizes.push_back({b.descriptorType, 1});
    VkDescriptorPoolCreateInfo dpci{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
    dpci.maxSets = 1;
    dpci.poolSizeCount = std::uint32_t(sizes.size());
    dpci.pPoolSizes = sizes.data();
    VkDescriptorPool pool;
    check(vkCreateDescriptorPool(dev, &dpci, nullptr, &pool), "vkCreateDescriptorPool");
    c.add([=] { vkDestroyDescriptorPool(dev, pool, nullptr); });
    VkDescriptorSetAllocateInfo dsai{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
    dsai.descriptorPool = pool;
    dsai.descriptorSetCount = 1;
    dsai.pSetLayouts = &dsl;
    VkDescriptorSet set;
    check(vkAllocateDescriptorSets(dev, &dsai, &set), "vkAllocateDescriptorSets");
    VkDescriptorBufferInfo in_info{in_buf, 0, VK_WHOLE_SIZE}, out_info{out_buf, 0, VK_WHOLE_SIZE};
    std::vector<VkWriteDescriptorSet> writes;
    auto write = [&](std::uint32_t b, VkDescriptorType t, const VkDescriptorImageInfo* ii2, const VkDescriptorBufferInfo* bi) {
        VkWriteDescriptorSet w{VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
        w.dstSet = set;
        w.dstBinding = b;
        w.descriptorCount = 1;
        w.descriptorType = t;
        w.pImageInfo = ii2;
        w.pBufferInfo = bi;
        writes.push_back(w);
    };
    for (std::uint32_t t = 0; t < k; ++t) {
        if (separate_sampler) {
            write(2 * t, VK_DESCRIPTOR_TYPE_SAMPLED_IMAGE, &uploaded[t].info, nullptr);
            write(2 * t + 1, VK_DESCRIPTOR_TYPE_SAMPLER, &uploaded[t].info, nullptr);
        } else {
            write(t, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, &uploaded[t].info, nullptr);
        }
    }
    write(in_binding, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, nullptr, &in_info);
    write(out_binding, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, nullptr, &out_info);
    vkUpdateDescriptorSets(dev, std::uint32_t(writes.size()), writes.data(), 0, nullptr);

    // Pipeline.
    VkShaderModuleCreateInfo smci{VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
    smci.codeSize = spirv.size() * 4;
    smci.pCode = spirv.data();
    VkShaderModule module;
    check(vkCreateShaderModule(dev, &smci, nullptr, &module), "vkCreateShaderModule");
    c.add([=] { vkDestroyShaderModule(dev, module, nullptr); });
    VkPipelineLayoutCreateInfo plci{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
    plci.setLayoutCount = 1;
    plci.pSetLayouts = &dsl;
    VkPipelineLayout layout;
    check(vkCreatePipelineLayout(dev, &plci, nullptr, &layout), "vkCreatePipelineLayout");
    c.add([=] { vkDestroyPipelineLayout(dev, layout, nullptr); });
    VkComputePipelineCreateInfo cpci{VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO};
    cpci.stage = {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO};
    cpci.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
    cpci.stage.module = module;
    cpci.stage.pName = "main";
    cpci.layout = layout;
    VkPipeline pipeline;
    check(vkCreateComputePipelines(dev, VK_NULL_HANDLE, 1, &cpci, nullptr, &pipeline), "vkCreateComputePipelines");
    c.add([=] { vkDestroyPipeline(dev, pipeline, nullptr); });

    // Commands: upload (with layout transitions), dispatch, make the writes visible to the host.
    VkCommandPoolCreateInfo cpi{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
    cpi.queueFamilyIndex = family;
    VkCommandPool cmd_pool;
    check(vkCreateCommandPool(dev, &cpi, nullptr, &cmd_pool), "vkCreateCommandPool");
    c.add([=] { vkDestroyCommandPool(dev, cmd_pool, nullptr); });
    VkCommandBufferAllocateInfo cbai{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
    cbai.commandPool = cmd_pool;
    cbai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    cbai.commandBufferCount = 1;
    VkCommandBuffer cmd;
    check(vkAllocateCommandBuffers(dev, &cbai, &cmd), "vkAllocateCommandBuffers");
    VkCommandBufferBeginInfo cbbi{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
    cbbi.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    check(vkBeginCommandBuffer(cmd, &cbbi), "vkBeginCommandBuffer");
    for (const auto& u : uploaded) {
        VkImageMemoryBarrier to_dst{VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER};
        to_dst.srcAccessMask = 0;
        to_dst.dstAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
        to_dst.oldLayout = VK_IMAGE_LAYOUT_UNDEFINED;
        to_dst.newLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
        to_dst.srcQueueFamilyIndex = to_dst.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
        to_dst.image = u.image;
        to_dst.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
        vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 0, nullptr, 0,
                             nullptr, 1, &to_dst);
        VkBufferImageCopy region{};
        region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
        region.imageExtent = u.extent;
        vkCmdCopyBufferToImage(cmd, u.staging, u.image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);
        VkImageMemoryBarrier to_read = to_dst;
        to_read.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
        to_read.dstAccessMask = VK_ACCESS_SHADER_READ_BIT;
        to_read.oldLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
        to_read.newLayout = VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL;
        vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, 0, 0, nullptr,
                             0, nullptr, 1, &to_read);
    }
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline);
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout, 0, 1, &set, 0, nullptr);
    vkCmdDispatch(cmd, std::uint32_t(padded / 64), 1, 1);
    VkMemoryBarrier to_host{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
    to_host.srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT;
    to_host.dstAccessMask = VK_ACCESS_HOST_READ_BIT;
    vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_PIPELINE_STAGE_HOST_BIT, 0, 1, &to_host, 0, nullptr, 0, nullptr);
    check(vkEndCommandBuffer(cmd), "vkEndCommandBuffer");
    VkFenceCreateInfo fci{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
    VkFence fence;
    check(vkCreateFence(dev, &fci, nullptr, &fence), "vkCreateFence");
    c.add([=] { vkDestroyFence(dev, fence, nullptr); });
    VkSubmitInfo si{VK_STRUCTURE_TYPE_SUBMIT_INFO};
    si.commandBufferCount = 1;
    si.pCommandBuffers = &cmd;
    check(vkQueueSubmit(queue, 1, &si, fence), "vkQueueSubmit");
    check(vkWaitForFences(dev, 1, &fence, VK_TRUE, 60ull * 1000 * 1000 * 1000), "vkWaitForFences");
    result.values.assign(static_cast<const float*>(out_map), static_cast<const float*>(out_map) + count * outputs_per_input);
    return result;
}

inline ComputeResult run_compute(const std::vector<std::uint32_t>& spirv, const ComputeTexture& texture,
                                 const std::vector<float>& inputs_vec4, bool separate_sampler) {
    return run_compute(spirv, std::vector<ComputeTexture>{texture}, inputs_vec4, separate_sampler, 1);
}

}  // namespace ms::testing
#else
namespace ms::testing {
inline ComputeResult run_compute(const std::vector<std::uint32_t>&, const ComputeTexture&, const std::vector<float>&, bool) {
    ComputeResult r;
    r.skip = "built without Vulkan (libvulkan-dev not found by CMake)";
    return r;
}
inline ComputeResult run_compute(const std::vector<std::uint32_t>&, const std::vector<ComputeTexture>&, const std::vector<float>&, bool,
                                 std::uint32_t) {
    ComputeResult r;
    r.skip = "built without Vulkan (libvulkan-dev not found by CMake)";
    return r;
}
}  // namespace ms::testing
#endif
