//! WGSL sources and a tiny `#import NAME` preprocessor: each pass is one file in `shaders/`,
//! and shared code (camera, rng, problem: the passes' bindings, ncc, geometric, prior) lives
//! in `shaders/shared/NAME.wgsl`. The
//! sources are compiled into the binary, so mvscope runs from anywhere.

use super::{GpuContext, GpuError};

/// Shared includes, by the name `#import` uses.
const SHARED: &[(&str, &str)] = &[
    ("camera", include_str!("../../shaders/shared/camera.wgsl")),
    ("rng", include_str!("../../shaders/shared/rng.wgsl")),
    ("problem", include_str!("../../shaders/shared/problem.wgsl")),
    ("ncc", include_str!("../../shaders/shared/ncc.wgsl")),
    (
        "geometric",
        include_str!("../../shaders/shared/geometric.wgsl"),
    ),
    ("prior", include_str!("../../shaders/shared/prior.wgsl")),
];

/// Resolves `#import NAME` lines (each include once, recursively, in order of first use).
pub fn preprocess(name: &str, source: &str) -> Result<String, GpuError> {
    let mut out = String::new();
    let mut included = Vec::new();
    expand(name, source, &mut out, &mut included, 0)?;
    Ok(out)
}

fn expand(
    name: &str,
    source: &str,
    out: &mut String,
    included: &mut Vec<String>,
    depth: usize,
) -> Result<(), GpuError> {
    if depth > 16 {
        return Err(GpuError::Shader {
            name: name.to_string(),
            message: "#import nesting deeper than 16: an import cycle?".into(),
        });
    }
    for line in source.lines() {
        match line.trim().strip_prefix("#import") {
            Some(rest) => {
                let import = rest.trim();
                if included.iter().any(|i| i == import) {
                    continue;
                }
                let Some((_, text)) = SHARED.iter().find(|(n, _)| *n == import) else {
                    return Err(GpuError::Shader {
                        name: name.to_string(),
                        message: format!("#import {import}: no shaders/shared/{import}.wgsl"),
                    });
                };
                included.push(import.to_string());
                expand(import, text, out, included, depth + 1)?;
            }
            None => {
                out.push_str(line);
                out.push('\n');
            }
        }
    }
    Ok(())
}

/// Preprocesses and compiles a shader; a WGSL error becomes a [`GpuError`] naming the shader.
pub fn create_module(
    ctx: &GpuContext,
    name: &str,
    source: &str,
) -> Result<wgpu::ShaderModule, GpuError> {
    let code = preprocess(name, source)?;
    ctx.checked(&format!("shader {name}"), || {
        ctx.device
            .create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(name),
                source: wgpu::ShaderSource::Wgsl(code.into()),
            })
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn imports_are_inlined_once() {
        let src = "#import camera\n#import camera\nfn f() {}\n";
        let out = preprocess("t", src).unwrap();
        assert_eq!(out.matches("struct Camera").count(), 1);
        assert!(out.ends_with("fn f() {}\n"));
    }

    #[test]
    fn unknown_import_is_an_error() {
        let err = preprocess("t", "#import nope\n").unwrap_err();
        assert!(
            err.to_string().contains("shaders/shared/nope.wgsl"),
            "{err}"
        );
    }
}
