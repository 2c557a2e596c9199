//! The brute-force oracle: every record in one list, every query a scan. No octree to get wrong,
//! so the caches are tested against it (and the linearizability checker uses it as the
//! sequential specification).

use super::CacheConfig;
use crate::ic::{self, Accumulator, InsertError, Interpolated, Record, WorkerId};
use glam::Vec3;

/// A list of records answered by scanning all of them.
#[derive(Clone, Debug)]
pub struct BruteForce {
    config: CacheConfig,
    records: Vec<Record>,
}

impl BruteForce {
    /// An empty oracle with the same bounds and accuracy as a cache built from `config`.
    pub fn new(config: CacheConfig) -> Self {
        Self {
            config,
            records: Vec::new(),
        }
    }

    /// Stores `record` as it is (with whatever id it carries) after the same checks a cache makes.
    pub fn insert(&mut self, record: Record) -> Result<(), InsertError> {
        self.config.check(&record)?;
        self.records.push(record);
        Ok(())
    }

    /// Every record stored.
    pub fn records(&self) -> &[Record] {
        &self.records
    }

    /// The interpolated irradiance a cache holding exactly these records must answer.
    pub fn lookup(
        &self,
        point: Vec3,
        normal: Vec3,
        asker: Option<WorkerId>,
    ) -> Option<Interpolated> {
        if !ic::is_valid_query(point, normal) {
            return None;
        }
        let mut acc = Accumulator::new(point, normal, self.config.accuracy(), asker);
        self.records.iter().for_each(|r| {
            acc.add(r);
        });
        acc.finish()
    }

    /// The records valid at `point`/`normal`.
    pub fn valid_records(&self, point: Vec3, normal: Vec3) -> Vec<Record> {
        ic::valid_among(&self.records, point, normal, self.config.accuracy())
            .copied()
            .collect()
    }
}
