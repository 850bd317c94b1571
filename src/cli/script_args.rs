//! Options shared by the subcommands that load SceneLang scripts (`#[command(flatten)]`),
//! so each is parsed, checked and documented once: the script's inputs ([`ScriptArgs`]),
//! changes to the loaded scene ([`SceneOverrides`]) and the sample count ([`SppArgs`]).

use std::path::Path;

use anyhow::{anyhow, bail};
use clap::Args;

use super::number_args::{finite, whole};

use crate::scene::{renderable_size, renderable_size_rule, Scene};
use crate::scenelang::{load_file_with_output, LoadOptions};

/// Most camera samples per pixel `--spp` accepts.
pub const MAX_SPP: u32 = 1 << 20;

/// `--time` and `--vars`.
#[derive(Debug, Clone, Default, Args)]
pub struct ScriptArgs {
    /// Value of TIME in the script.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true, value_parser = finite)]
    pub time: f64,
    /// Variables defined before the script runs, as "name value, name value" (values in SET
    /// syntax); they win over the script's own SET of the same name. May repeat.
    #[arg(long)]
    pub vars: Vec<String>,
}

impl ScriptArgs {
    /// Loads `path` with these variables at `time`; the error is the script's full diagnostic
    /// on its own line, so that `file:line:col:` starts a line (where editors look for it).
    pub fn load_at(&self, path: &Path, time: f64) -> anyhow::Result<Scene> {
        self.load_at_with_output(path, time, &mut std::io::stdout().lock())
    }

    /// [`Self::load_at`] with the script's DUMP output written to `out`.
    pub fn load_at_with_output(&self, path: &Path, time: f64, out: &mut dyn std::io::Write) -> anyhow::Result<Scene> {
        let opts = LoadOptions { time, vars: self.vars.clone() };
        load_file_with_output(path, &opts, out).map_err(|e| anyhow!("the scene does not load\n{e}"))
    }

    /// Loads `path` at `--time`.
    pub fn load(&self, path: &Path) -> anyhow::Result<Scene> {
        self.load_at(path, self.time)
    }
}

/// `--width`, `--height` and `--seed`: what the command line changes in a loaded scene.
#[derive(Debug, Clone, Default, Args)]
pub struct SceneOverrides {
    /// Image width in pixels. Given alone, the height follows from the camera's aspect ratio.
    #[arg(long, value_parser = image_side(), allow_negative_numbers = true)]
    pub width: Option<u32>,
    /// Image height in pixels. Given alone, the width follows from the camera's aspect ratio.
    #[arg(long, value_parser = image_side(), allow_negative_numbers = true)]
    pub height: Option<u32>,
    /// Replaces the state of the tracer's Pcg seed.
    #[arg(long, value_parser = whole::<u64>(0, u64::MAX), allow_negative_numbers = true)]
    pub seed: Option<u64>,
}

/// `--width` and `--height`: 1 to [`crate::scene::MAX_IMAGE_SIDE`], refused when parsed by
/// every command alike (a `bench` run would otherwise report a 0-pixel size per scene).
fn image_side() -> impl Fn(&str) -> Result<u32, String> + Clone + Send + Sync + 'static {
    whole(1, u64::from(crate::scene::MAX_IMAGE_SIDE))
}

impl SceneOverrides {
    /// Applies the size ([`resize`]) and the seed.
    pub fn apply(&self, scene: &mut Scene) -> anyhow::Result<()> {
        resize(scene, self.width, self.height)?;
        if let Some(seed) = self.seed {
            scene.tracer.rng.state = seed;
        }
        Ok(())
    }
}

/// `--spp`.
#[derive(Debug, Clone, Copy, Default, Args)]
pub struct SppArgs {
    /// Camera samples per pixel (a perfect square s² gives s×s strata), instead of the
    /// tracer's samples_per_side².
    #[arg(long, value_parser = whole::<u32>(1, u64::from(MAX_SPP)), allow_negative_numbers = true)]
    pub spp: Option<u32>,
}

impl SppArgs {
    /// The count, checked against `1..=max`.
    pub fn checked(&self, max: u32) -> anyhow::Result<Option<u32>> {
        match self.spp {
            Some(spp) if spp == 0 || spp > max => bail!("--spp must be 1..={max}, got {spp}"),
            spp => Ok(spp),
        }
    }
}

/// Applies `--width/--height`: both given replace the size (the camera keeps the script's
/// aspect ratio); one alone sets that side and derives the other from the camera's aspect
/// ratio, so pixels stay square.
pub fn resize(scene: &mut Scene, width: Option<u32>, height: Option<u32>) -> anyhow::Result<()> {
    let aspect = scene.camera.aspect_ratio;
    let derive = |v: f64| -> u32 { v.round().clamp(1.0, f64::from(u32::MAX)) as u32 };
    let (w, h) = match (width, height) {
        (None, None) => return Ok(()),
        (Some(w), Some(h)) => (w, h),
        (Some(w), None) => (w, derive(f64::from(w) / aspect)),
        (None, Some(h)) => (derive(f64::from(h) * aspect), h),
    };
    if !renderable_size(w, h) {
        // A side derived from the camera's aspect ratio is named with what it came from.
        let rule = renderable_size_rule();
        match (width, height) {
            (Some(_), None) => bail!(
                "--width {w} at the camera's aspect ratio {aspect:.4} gives image size {w}×{h}, which cannot be \
                 rendered: {rule}"
            ),
            (None, Some(_)) => bail!(
                "--height {h} at the camera's aspect ratio {aspect:.4} gives image size {w}×{h}, which cannot be \
                 rendered: {rule}"
            ),
            _ => bail!("image size {w}×{h} cannot be rendered: {rule}"),
        }
    }
    scene.width = w;
    scene.height = h;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::SceneBuilder;
    use clap::Parser;

    #[test]
    fn size_overrides_keep_square_pixels_when_one_side_is_given() {
        let mut s = SceneBuilder::new(160, 90).build().unwrap();
        s.camera.aspect_ratio = 16.0 / 9.0;
        resize(&mut s, Some(320), None).unwrap();
        assert_eq!((s.width, s.height), (320, 180));
        resize(&mut s, None, Some(45)).unwrap();
        assert_eq!((s.width, s.height), (80, 45));
        resize(&mut s, Some(10), Some(10)).unwrap();
        assert_eq!((s.width, s.height, s.camera.aspect_ratio), (10, 10, 16.0 / 9.0));
        assert!(resize(&mut s, Some(0), None).is_err());
        assert!(resize(&mut s, Some(crate::scene::MAX_IMAGE_SIDE + 1), Some(1)).is_err());
        // Both sides within the limit, the whole past what an image file holds (2²⁸ pixels).
        let e = resize(&mut s, Some(32_768), Some(32_768)).unwrap_err().to_string();
        assert_eq!(
            e,
            "image size 32768×32768 cannot be rendered: each side from 1 to 32768, and at most 268435456 pixels in all"
        );
        resize(&mut s, Some(32_768), Some(8_192)).unwrap();
        // A side derived from the aspect ratio says where it came from.
        let e = resize(&mut s, None, Some(30_000)).unwrap_err().to_string();
        assert!(
            e.starts_with("--height 30000 at the camera's aspect ratio 1.7778 gives image size 53333×30000, which"),
            "{e}"
        );
        let e = resize(&mut s, Some(32_768), None).unwrap_err().to_string();
        assert!(e.starts_with("--width 32768 at the camera's aspect ratio 1.7778 gives image size 32768×18432"), "{e}");
    }

    #[derive(Parser)]
    struct T {
        #[command(flatten)]
        script: ScriptArgs,
        #[command(flatten)]
        scene: SceneOverrides,
        #[command(flatten)]
        spp: SppArgs,
    }

    #[test]
    fn shared_arguments_parse_alike() {
        let t = T::try_parse_from(["t", "--time", "-2", "--vars", "r 1", "--width", "9", "--seed", "7", "--spp", "4"])
            .unwrap();
        assert_eq!((t.script.time, t.script.vars.as_slice()), (-2.0, &["r 1".to_string()][..]));
        assert_eq!((t.scene.width, t.scene.height, t.scene.seed), (Some(9), None, Some(7)));
        assert_eq!(t.spp.checked(MAX_SPP).unwrap(), Some(4));
        let mut s = SceneBuilder::new(16, 8).build().unwrap();
        s.camera.aspect_ratio = 2.0;
        t.scene.apply(&mut s).unwrap();
        assert_eq!((s.width, s.height, s.tracer.rng.state), (9, 5, 7));
        assert!(SppArgs { spp: Some(0) }.checked(MAX_SPP).is_err());
        assert!(SppArgs { spp: Some(5) }.checked(4).is_err());
    }
}
