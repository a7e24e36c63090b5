//! cpfg colour maps (`*.map`) and material files (`*.mat`): the colours of the
//! turtle's colour / material indices (`;`, `,` and `;(i)`).
//!
//! Part of the model-folder support of issue 3. Both are binary files:
//!
//! - **`.map`** (vlab `palette`, cpfg `-m`): 256 entries of three bytes R, G, B, entry
//!   0 first (768 bytes). Files with a different length are read as
//!   ⌊length / 3⌋ entries (trailing bytes ignored); an empty file is an error.
//! - **`.mat`** (vlab `medit`, cpfg `-M`): records of 15 bytes: the material index,
//!   transparency, ambient R G B, diffuse R G B, emission R G B, specular R G B and
//!   shininess (0–128), every colour byte scaled by 1/255. Indices without a record
//!   keep OpenGL's default material (ambient 0.2, diffuse 0.8, no emission or
//!   specular). A trailing partial record is ignored.
//!
//! [`ColorMap::colors`] holds one RGB colour per index as stored in the file (display
//! values in \[0, 1\], not linearized); for materials it is the diffuse colour, and
//! [`ColorMap::materials`] keeps the full records. cpfg's `-m2` loads a second map at
//! indices 256–511; [`ColorMap::insert_at`] does that.

/// One medit material.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CpfgMaterial {
    /// Ambient colour.
    pub ambient: [f32; 3],
    /// Diffuse colour.
    pub diffuse: [f32; 3],
    /// Emitted colour.
    pub emission: [f32; 3],
    /// Specular colour.
    pub specular: [f32; 3],
    /// Specular exponent, 0–128 (OpenGL's).
    pub shininess: f32,
    /// Transparency, 0 (opaque) to 1.
    pub transparency: f32,
    /// `true` when the file has a record for this index.
    pub defined: bool,
}

impl Default for CpfgMaterial {
    /// OpenGL's default material, which medit uses for undefined entries.
    fn default() -> Self {
        CpfgMaterial {
            ambient: [0.2; 3],
            diffuse: [0.8; 3],
            emission: [0.0; 3],
            specular: [0.0; 3],
            shininess: 0.0,
            transparency: 0.0,
            defined: false,
        }
    }
}

/// Colours by colour / material index.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ColorMap {
    /// RGB in \[0, 1\] per index (the diffuse colour for materials).
    pub colors: Vec<[f32; 3]>,
    /// The full material records when read from a `.mat` file (same length as `colors`).
    pub materials: Option<Vec<CpfgMaterial>>,
}

impl ColorMap {
    /// The colour of `index`, if the map has one.
    pub fn color(&self, index: i64) -> Option<[f32; 3]> {
        usize::try_from(index).ok().and_then(|i| self.colors.get(i)).copied()
    }

    /// Copies `other` into this map starting at index `base`, growing it as needed
    /// (new entries in between are black, or the default material).
    pub fn insert_at(&mut self, base: usize, other: &ColorMap) {
        let need = base + other.colors.len();
        if self.colors.len() < need {
            self.colors.resize(need, [0.0; 3]);
        }
        self.colors[base..need].copy_from_slice(&other.colors);
        if self.materials.is_some() || other.materials.is_some() {
            let mut mine = self.materials.take().unwrap_or_default();
            if mine.len() < self.colors.len() {
                mine.resize(self.colors.len(), CpfgMaterial::default());
            }
            match &other.materials {
                Some(m) => mine[base..need].copy_from_slice(m),
                None => {
                    for (k, c) in other.colors.iter().enumerate() {
                        mine[base + k] =
                            CpfgMaterial { diffuse: *c, ambient: *c, defined: true, ..Default::default() };
                    }
                }
            }
            self.materials = Some(mine);
        }
    }
}

fn unit(b: u8) -> f32 {
    b as f32 / 255.0
}

/// Reads a binary `.map` colour map.
pub fn parse(bytes: &[u8]) -> Result<ColorMap, String> {
    if bytes.len() < 3 {
        return Err(format!("a colour map needs 3 bytes per colour, the file has {}", bytes.len()));
    }
    let colors = bytes.chunks_exact(3).map(|c| [unit(c[0]), unit(c[1]), unit(c[2])]).collect();
    Ok(ColorMap { colors, materials: None })
}

/// Reads a binary `.mat` material file (256 materials; see the module documentation).
pub fn parse_materials(bytes: &[u8]) -> Result<ColorMap, String> {
    let mut mats = vec![CpfgMaterial::default(); 256];
    for r in bytes.chunks_exact(15) {
        let rgb = |k: usize| [unit(r[k]), unit(r[k + 1]), unit(r[k + 2])];
        mats[r[0] as usize] = CpfgMaterial {
            transparency: unit(r[1]),
            ambient: rgb(2),
            diffuse: rgb(5),
            emission: rgb(8),
            specular: rgb(11),
            shininess: r[14] as f32,
            defined: true,
        };
    }
    Ok(ColorMap { colors: mats.iter().map(|m| m.diffuse).collect(), materials: Some(mats) })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn map_entries_are_interleaved_rgb() {
        let mut b = vec![0u8; 768];
        b[3..6].copy_from_slice(&[255, 255, 0]);
        let m = parse(&b).unwrap();
        assert_eq!(m.colors.len(), 256);
        assert_eq!(m.color(1), Some([1.0, 1.0, 0.0]));
        assert_eq!(m.color(-1), None);
        assert_eq!(m.color(256), None);
        assert_eq!(parse(&b[..7]).unwrap().colors.len(), 2);
        assert!(parse(&[]).is_err());
    }

    #[test]
    fn materials_by_index() {
        let rec = [3u8, 0, 10, 20, 30, 255, 0, 51, 0, 0, 0, 1, 2, 3, 16];
        let mut bytes = rec.to_vec();
        bytes.extend_from_slice(&[9, 9]); // partial record
        let m = parse_materials(&bytes).unwrap();
        assert_eq!(m.colors.len(), 256);
        assert_eq!(m.color(3), Some([1.0, 0.0, 0.2]));
        let mats = m.materials.as_ref().unwrap();
        assert!(mats[3].defined && !mats[4].defined);
        assert_eq!(mats[3].shininess, 16.0);
        assert_eq!(m.color(0), Some([0.8; 3]));
        assert!(parse_materials(&[]).is_ok());
    }

    #[test]
    fn second_map_at_256() {
        let a = parse(&[1u8; 768]).unwrap();
        let b = parse(&[2u8; 6]).unwrap();
        let mut m = ColorMap::default();
        m.insert_at(256, &b);
        m.insert_at(0, &a);
        assert_eq!(m.colors.len(), 258);
        assert_eq!(m.color(257), Some([2.0 / 255.0; 3]));
        assert_eq!(m.color(0), Some([1.0 / 255.0; 3]));
    }
}
