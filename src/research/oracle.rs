//! The brute-force oracle: every record in one list, every query a scan. No octree to get wrong,
//! so the caches are tested against it (and the linearizability checker uses it as the
//! sequential specification).

use crate::cache::CacheConfig;
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ic::RecordId;

    /// A record at `x` on the line y = z = 1, facing +z, of radius 1 and irradiance `e`.
    fn at(x: f32, e: f32, seq: u64) -> Record {
        Record::new(Vec3::new(x, 1.0, 1.0), Vec3::Z, Vec3::splat(e), 1.0).sealed(RecordId::new(
            WorkerId::new(1),
            0,
            seq,
        ))
    }

    /// The oracle worked by hand: it keeps what it is given in order, refuses what a cache
    /// refuses, and answers with exactly the records valid at the query.
    #[test]
    fn the_oracle_keeps_refuses_and_answers_by_hand() {
        let config = CacheConfig::new(Vec3::ZERO, Vec3::splat(4.0), 0.5).unwrap();
        let mut oracle = BruteForce::new(config);
        let (a, b, far) = (at(1.0, 1.0, 0), at(1.2, 3.0, 1), at(3.0, 7.0, 2));
        for r in [a, b, far] {
            oracle.insert(r).unwrap();
        }
        assert!(
            oracle.insert(at(9.0, 1.0, 3)).is_err(),
            "outside the bounds"
        );
        assert_eq!(oracle.records(), &[a, b, far]);

        // At x = 1.1 both near records are 0.1 away (weight 1 / 0.1 = 10 > 1 / a = 2, no
        // gradients) and the far one 1.9 (weight 0.53): the answer is the mean of 1 and 3.
        let q = Vec3::new(1.1, 1.0, 1.0);
        assert_eq!(oracle.valid_records(q, Vec3::Z), vec![a, b]);
        let hit = oracle.lookup(q, Vec3::Z, Some(WorkerId::new(0))).unwrap();
        assert_eq!((hit.records, hit.foreign), (2, 2));
        assert!((hit.irradiance - Vec3::splat(2.0)).abs().max_element() < 1e-5);
        assert!((hit.weight - 20.0).abs() < 1e-3, "{}", hit.weight);
        // The asker's own records are not foreign.
        let own = oracle.lookup(q, Vec3::Z, Some(WorkerId::new(1))).unwrap();
        assert_eq!(own.foreign, 0);
        // Nothing is valid at x = 2; a query that is not finite is not answered.
        assert_eq!(oracle.lookup(Vec3::new(2.0, 1.0, 1.0), Vec3::Z, None), None);
        assert!(oracle
            .valid_records(Vec3::new(2.0, 1.0, 1.0), Vec3::Z)
            .is_empty());
        assert_eq!(oracle.lookup(Vec3::NAN, Vec3::Z, None), None);
        assert!(oracle.valid_records(q, Vec3::ZERO).is_empty());
    }
}
