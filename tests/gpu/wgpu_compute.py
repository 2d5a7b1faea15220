"""Runs WGSL compute shaders with wgpu (the `wgpu` PyPI package; Mesa lavapipe on a CPU-only machine),
for the WGSL shader tests (tests/support/wgpu_runner.hpp writes the spec and reads the results).

    python wgpu_compute.py SPEC.json

SPEC: {"jobs": [{"shader": F.wgsl, "inputs": F.bin (float32 vec4s), "outputs": F.bin, "output_count": N,
                 "textures": [{"data": F.bin, "width", "height", "depth", "dimension": "2d" | "3d",
                               "format": "rgba32float" | "rgba16float"}]}]}
Bindings (group 0): texture k at 2k, its sampler (linear, clamp-to-edge, level 0) at 2k + 1, then the
inputs (read-only storage) and the outputs (storage, N float32). One workgroup of 64 per 64 inputs.
Prints the adapter on the first line; exit status 3 when no adapter or feature is available (a skip).
"""

import json
import sys

import wgpu


def main(spec_path):
    spec = json.load(open(spec_path))
    adapter = wgpu.gpu.request_adapter_sync(power_preference="low-power")
    if adapter is None:
        print("no WebGPU adapter")
        return 3
    info = adapter.info
    print(f"{info['device']} ({info['backend_type']}, {info['adapter_type']})")
    features = []
    if any(t["format"] == "rgba32float" for job in spec["jobs"] for t in job["textures"]):
        # Float32 textures filter only with this feature (WebGPU core filters 16-bit floats only).
        if "float32-filterable" not in adapter.features:
            print("the adapter cannot filter rgba32float textures (no float32-filterable)")
            return 3
        features.append("float32-filterable")
    device = adapter.request_device_sync(required_features=features)
    sampler = device.create_sampler(mag_filter="linear", min_filter="linear", mipmap_filter="nearest",
                                    address_mode_u="clamp-to-edge", address_mode_v="clamp-to-edge",
                                    address_mode_w="clamp-to-edge", lod_min_clamp=0, lod_max_clamp=0)
    compute = wgpu.ShaderStage.COMPUTE
    for job in spec["jobs"]:
        module = device.create_shader_module(code=open(job["shader"]).read())
        layout_entries, entries = [], []
        for k, t in enumerate(job["textures"]):
            bytes_per_texel = 16 if t["format"] == "rgba32float" else 8
            size = (t["width"], t["height"], t["depth"] if t["dimension"] == "3d" else 1)
            texture = device.create_texture(size=size, dimension=t["dimension"], format=t["format"],
                                            usage=wgpu.TextureUsage.TEXTURE_BINDING | wgpu.TextureUsage.COPY_DST)
            device.queue.write_texture({"texture": texture, "mip_level": 0, "origin": (0, 0, 0)},
                                       open(t["data"], "rb").read(),
                                       {"offset": 0, "bytes_per_row": t["width"] * bytes_per_texel,
                                        "rows_per_image": t["height"]}, size)
            layout_entries.append({"binding": 2 * k, "visibility": compute,
                                   "texture": {"sample_type": "float", "view_dimension": t["dimension"]}})
            layout_entries.append({"binding": 2 * k + 1, "visibility": compute, "sampler": {"type": "filtering"}})
            entries.append({"binding": 2 * k, "resource": texture.create_view()})
            entries.append({"binding": 2 * k + 1, "resource": sampler})
        inputs = open(job["inputs"], "rb").read()
        count = len(inputs) // 16
        padded = (count + 63) // 64 * 64
        in_buf = device.create_buffer_with_data(data=inputs + bytes(16 * (padded - count)),
                                                usage=wgpu.BufferUsage.STORAGE)
        out_size = 4 * max(job["output_count"], 1)
        out_buf = device.create_buffer(size=out_size, usage=wgpu.BufferUsage.STORAGE | wgpu.BufferUsage.COPY_SRC)
        b = 2 * len(job["textures"])
        layout_entries.append({"binding": b, "visibility": compute, "buffer": {"type": "read-only-storage"}})
        layout_entries.append({"binding": b + 1, "visibility": compute, "buffer": {"type": "storage"}})
        entries.append({"binding": b, "resource": {"buffer": in_buf, "offset": 0, "size": in_buf.size}})
        entries.append({"binding": b + 1, "resource": {"buffer": out_buf, "offset": 0, "size": out_size}})
        bind_layout = device.create_bind_group_layout(entries=layout_entries)
        pipeline = device.create_compute_pipeline(
            layout=device.create_pipeline_layout(bind_group_layouts=[bind_layout]),
            compute={"module": module, "entry_point": "main"})
        bind_group = device.create_bind_group(layout=bind_layout, entries=entries)
        encoder = device.create_command_encoder()
        compute_pass = encoder.begin_compute_pass()
        compute_pass.set_pipeline(pipeline)
        compute_pass.set_bind_group(0, bind_group)
        compute_pass.dispatch_workgroups(padded // 64, 1, 1)
        compute_pass.end()
        device.queue.submit([encoder.finish()])
        open(job["outputs"], "wb").write(bytes(device.queue.read_buffer(out_buf)))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1]))
