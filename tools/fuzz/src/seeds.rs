//! Valid seed files per format: small ones made here (every feature of the format the loader reads, so that
//! mutations reach it), and the shipped assets where they are small enough to mutate quickly.

use std::path::PathBuf;

fn assets() -> PathBuf {
    crate::crate_dir().join("../../assets")
}

fn read(path: PathBuf) -> Option<Vec<u8>> {
    std::fs::read(path).ok()
}

/// OBJ: positions, normals, texture coordinates, the `v/vt/vn` and `v//vn` forms, negative (relative) indices,
/// a polygon, groups and comments; and the head of the shipped bunny (its first 8 KiB of lines, with a face).
pub fn obj() -> Vec<Vec<u8>> {
    let mut out = vec![
        b"# a quad\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nf 1 3 4\n".to_vec(),
        b"o tri\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1/1 2/2/1 3/3/1\n".to_vec(),
        b"g a\nv -1 -1 0.5\nv 1 -1 0.5\nv 1 1 0.5\nv -1 1 0.5\nv 0 0 2\nvn 0 0 1\nf -5//1 -4//1 -3//1 -2//1\nf 1 2 5\n"
            .to_vec(),
        b"mtllib none.mtl\nusemtl m\ns 1\nv 0 0 0\nv 1e-3 0 0\nv 0 1e3 0\nf 3 2 1\n".to_vec(),
    ];
    if let Some(bunny) = read(assets().join("meshes/bunny.obj")) {
        let mut head: Vec<u8> = bunny.into_iter().take(8 << 10).collect();
        if let Some(end) = head.iter().rposition(|&b| b == b'\n') {
            head.truncate(end + 1);
        }
        head.extend_from_slice(b"f 1 2 3\nf 3 2 4\n");
        out.push(head);
    }
    out
}

/// The binary buffer of the glTF seeds: 4 positions, 4 normals, 6 u16 indices (two triangles).
fn gltf_buffer() -> Vec<u8> {
    let pos = [0f32, 0., 0., 1., 0., 0., 1., 1., 0., 0., 1., 0.];
    let nrm = [0f32, 0., 1., 0., 0., 1., 0., 0., 1., 0., 0., 1.];
    let mut bin: Vec<u8> = pos.iter().chain(nrm.iter()).flat_map(|f| f.to_le_bytes()).collect();
    bin.extend([0u16, 1, 2, 0, 2, 3].iter().flat_map(|i| i.to_le_bytes()));
    bin
}

/// The JSON of a glTF seed whose buffer is `buffer` (a `"uri"` member, or nothing for a GLB's BIN chunk).
fn gltf_json(buffer: &str) -> String {
    format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0,2]}}],
"nodes":[{{"translation":[0,2,0],"children":[1]}},{{"scale":[2,2,2],"rotation":[0,0,0,1],"mesh":0}},
{{"matrix":[1,0,0,0,0,1,0,0,0,0,1,0,3,0,0,1],"mesh":0}}],
"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0,"NORMAL":1}},"indices":2,"material":0}}]}}],
"materials":[{{"pbrMetallicRoughness":{{"baseColorFactor":[1,0,0,1],"metallicFactor":1.0,"roughnessFactor":0.5}}}}],
"buffers":[{{"byteLength":108{buffer}}}],
"bufferViews":[{{"buffer":0,"byteLength":96}},{{"buffer":0,"byteOffset":96,"byteLength":12}}],
"accessors":[{{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}},
{{"bufferView":0,"byteOffset":48,"componentType":5126,"count":4,"type":"VEC3"}},
{{"bufferView":1,"componentType":5123,"count":6,"type":"SCALAR"}}]}}"#
    )
}

/// glTF: a two-level node hierarchy (translation/rotation/scale and a matrix), normals, u16 indices, a
/// material; the buffer as a data URI.
pub fn gltf() -> Vec<Vec<u8>> {
    let uri = format!(r#","uri":"data:application/octet-stream;base64,{}""#, base64::encode(gltf_buffer()));
    // The lit room (scenes::gltf_writer::lit_room): cameras, KHR_lights_punctual lights and node extras.
    let room = include_bytes!("../../../examples/lit_room.gltf").to_vec();
    vec![gltf_json(&uri).into_bytes(), room]
}

/// GLB: the glTF seed as a binary container (JSON chunk, BIN chunk).
pub fn glb() -> Vec<Vec<u8>> {
    let mut json = gltf_json("").into_bytes();
    while !json.len().is_multiple_of(4) {
        json.push(b' ');
    }
    let mut bin = gltf_buffer();
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&json);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&bin);
    vec![out]
}

/// OpenEXR: 8×4 RGB maps, f32 and f16, uncompressed and with each compression the exr crate writes (RLE, ZIP,
/// ZIP16, PIZ), in scan lines and tiles. (The shipped maps are 1.4 and 2 MiB: too slow to mutate at a useful
/// rate; the corpus test loads them.)
pub fn exr() -> Vec<Vec<u8>> {
    use exr::prelude::*;
    let mut out = Vec::new();
    let compressions =
        [Compression::Uncompressed, Compression::RLE, Compression::ZIP1, Compression::ZIP16, Compression::PIZ];
    for (i, compression) in compressions.into_iter().enumerate() {
        for half in [false, true] {
            let blocks = if i % 2 == 0 { Blocks::ScanLines } else { Blocks::Tiles(Vec2(4, 4)) };
            let encoding = Encoding { compression, blocks, line_order: LineOrder::Increasing };
            let mut bytes = Vec::new();
            let written = if half {
                let channels = SpecificChannels::rgb(|Vec2(x, y)| {
                    (f16::from_f32(x as f32 * 0.25), f16::from_f32(y as f32), f16::from_f32(0.5))
                });
                Image::from_encoded_channels((8, 4), encoding, channels)
                    .write()
                    .to_buffered(std::io::Cursor::new(&mut bytes))
            } else {
                let channels = SpecificChannels::rgb(|Vec2(x, y)| (x as f32 * 0.25, y as f32, 0.5f32));
                Image::from_encoded_channels((8, 4), encoding, channels)
                    .write()
                    .to_buffered(std::io::Cursor::new(&mut bytes))
            };
            if written.is_ok() {
                out.push(bytes);
            }
        }
    }
    out
}

/// Radiance HDR: flat RGBE pixels (8×4) and new-style run-length scan lines (16×2, runs and literals). (The
/// loader reads the standard `-Y H +X W` orientation only; a `+Y` file is in the regression corpus.)
pub fn hdr() -> Vec<Vec<u8>> {
    let header =
        |res: &str| format!("#?RADIANCE\n# seed\nFORMAT=32-bit_rle_rgbe\nEXPOSURE=1.0\n\n{res}\n").into_bytes();
    let mut flat = header("-Y 4 +X 8");
    for i in 0..32u8 {
        flat.extend_from_slice(&[i * 7, 128, 255 - i, 129]);
    }
    let mut rle = header("-Y 2 +X 16");
    for _row in 0..2 {
        rle.extend_from_slice(&[2, 2, 0, 16]);
        // R: a run of 16; G: 16 literals; B: two runs of 8; E: a run of 16.
        rle.extend_from_slice(&[128 + 16, 200]);
        rle.push(16);
        rle.extend((0..16u8).map(|k| k * 15));
        rle.extend_from_slice(&[128 + 8, 10, 128 + 8, 250]);
        rle.extend_from_slice(&[128 + 16, 130]);
    }
    vec![flat, rle]
}

/// Sphere-set files: the shipped bunny's.
/// Scene descriptions: the two shipped examples.
pub fn scene() -> Vec<Vec<u8>> {
    let examples = assets().join("../examples");
    let mut out: Vec<Vec<u8>> =
        ["arm.toml", "still_life.toml", "glossy_light.toml"].iter().filter_map(|n| read(examples.join(n))).collect();
    out.push(ALL_KEYS.as_bytes().to_vec());
    out
}

/// A scene file with every numeric key (the mutations put f32's limits in each), its paths relative to
/// the examples folder.
const ALL_KEYS: &str = r#"[camera]
eye = [0.0, 1.6, 3.6]
target = [0.0, 0.5, 0.0]
fov_y = 45.0

[environment]
file = "../assets/envmaps/courtyard.exr"
intensity = 0.8
rotation = 120.0
lights = 4
light_threshold = 4.0
light_share = 1.0
light_radius = 15.0

[ground]
visible = true
subdivisions = 8
material = { brdf = "phong:e=10" }
material_map = { file = "../assets/textures/lafortune_map.png", levels = 8, material = { brdf = "phong:e=50" } }

[[light]]
center = [1.2, 2.2, 1.0]
radius = 0.25
radiance = [12.0, 10.0, 8.0]

[[model]]
file = "arm.gltf"
translation = [0.0, 0.1, 0.0]
rotation = [0.0, 30.0, 0.0]
scale = [1.0, 1.0, 1.0]
material = { diffuse = [0.8, 0.5, 0.4], specular = [0.1, 0.1, 0.1], shininess = 100.0 }
spheres = 0
clip = "bend"
"#;

pub fn spheres() -> Vec<Vec<u8>> {
    read(assets().join("meshes/bunny.spheres.json")).into_iter().collect()
}

/// Material libraries (`.mtl`): every statement the OBJ loader reads (colours of three numbers and of one, the
/// exponent, `d`, `Ni`, `illum`), two materials, comments and texture names (which the loader ignores).
pub fn mtl() -> Vec<Vec<u8>> {
    vec![
        b"# two materials\nnewmtl a\nKa 0 0 0\nKd 0.8 0.5 0.4\nKs 0.2 0.2 0.2\nNs 64\nd 1\nNi 1.5\nillum 2\n\
          newmtl b\nKd 0.3\nKs 0.04 0.04 0.04\nNs 1000\nmap_Kd b.png\n"
            .to_vec(),
        b"newmtl a\nKd 1 1 1 # white\nKe 0 0 0\n".to_vec(),
    ]
}

/// Material-map PNGs: 8-bit grey, RGB and RGBA, a palette image, and 16-bit grey (4×4 each).
pub fn png() -> Vec<Vec<u8>> {
    let mut out = Vec::new();
    let kinds = [
        (png::ColorType::Grayscale, png::BitDepth::Eight, 1usize),
        (png::ColorType::Rgb, png::BitDepth::Eight, 3),
        (png::ColorType::Rgba, png::BitDepth::Eight, 4),
        (png::ColorType::Indexed, png::BitDepth::Eight, 1),
        (png::ColorType::Grayscale, png::BitDepth::Sixteen, 2),
    ];
    for (color, depth, bytes_per_pixel) in kinds {
        let mut bytes = Vec::new();
        {
            let mut enc = png::Encoder::new(&mut bytes, 4, 4);
            enc.set_color(color);
            enc.set_depth(depth);
            if color == png::ColorType::Indexed {
                enc.set_palette((0..16u8).flat_map(|i| [i * 16, 255 - i * 16, 128]).collect::<Vec<u8>>());
            }
            let data: Vec<u8> = (0..16 * bytes_per_pixel).map(|i| (i * 37 % 256) as u8).collect();
            let data = if color == png::ColorType::Indexed { data.iter().map(|b| b % 16).collect() } else { data };
            if let Ok(mut w) = enc.write_header() {
                let _ = w.write_image_data(&data);
            }
        }
        out.push(bytes);
    }
    out
}
