//! The FMU-state calls of the driver: get, set (own, the other instance's, foreign, NULL
//! handles), free, serialize (round trip) and deserialize (damaged or random bytes).

use super::*;

/// A handle no instance handed out.
const FOREIGN: usize = 8;

impl<M: Model> Driver<M> {
    pub(super) unsafe fn state(&mut self, k: usize, op: &StateOp) {
        let s = match *op {
            StateOp::Get { slot, reuse, null } => self.get_state(k, slot, reuse, null),
            StateOp::Set { slot, from } => self.set_state(k, slot, from),
            StateOp::Free { slot, null } => self.free_state(k, slot, null),
            StateOp::Serialize { slot, short } => return self.serialize(k, slot, short),
            StateOp::Deserialize { .. } => self.deserialize(k, op),
        };
        self.insts[k].check(s, op);
    }

    fn own(&self, k: usize, slot: u8) -> Option<Fmi3FmuState> {
        let states = &self.insts[k].states;
        (!states.is_empty()).then(|| states[slot as usize % states.len()])
    }

    unsafe fn get_state(&mut self, k: usize, slot: u8, reuse: bool, null: bool) -> Fmi3Status {
        let mut st: Fmi3FmuState = std::ptr::null_mut();
        if reuse {
            st = self.own(k, slot).unwrap_or(st);
        }
        let p = if null {
            std::ptr::null_mut()
        } else {
            &mut st as *mut _
        };
        let s = f::fmi3GetFMUState(self.insts[k].c, p);
        if null {
            assert_eq!(s, FMI3_ERROR, "fmi3GetFMUState(NULL) accepted");
        }
        if s == FMI3_OK && !self.insts[k].states.contains(&st) {
            assert!(!st.is_null(), "fmi3GetFMUState gave a NULL state");
            self.insts[k].states.push(st);
        }
        s
    }

    /// `from`: 0 an own state, 1 one of the other instance, 2 a foreign pointer, 3 NULL; only
    /// an own state is accepted.
    unsafe fn set_state(&mut self, k: usize, slot: u8, from: u8) -> Fmi3Status {
        let null = std::ptr::null_mut();
        let st = match from % 4 {
            0 => self.own(k, slot).unwrap_or(null),
            1 => self.own(1 - k, slot).unwrap_or(null),
            2 => FOREIGN as Fmi3FmuState,
            _ => null,
        };
        let s = f::fmi3SetFMUState(self.insts[k].c, st);
        if from % 4 != 0 || st.is_null() {
            assert_eq!(
                s, FMI3_ERROR,
                "fmi3SetFMUState of a state not this instance's accepted"
            );
        }
        s
    }

    unsafe fn free_state(&mut self, k: usize, slot: u8, null: bool) -> Fmi3Status {
        let c = self.insts[k].c;
        if null {
            let s = f::fmi3FreeFMUState(c, std::ptr::null_mut());
            assert_eq!(s, FMI3_ERROR, "fmi3FreeFMUState(NULL) accepted");
            return s;
        }
        let states = &self.insts[k].states;
        if states.is_empty() {
            let mut st = FOREIGN as Fmi3FmuState;
            let s = f::fmi3FreeFMUState(c, &mut st);
            assert_eq!(
                s, FMI3_ERROR,
                "fmi3FreeFMUState of a foreign state accepted"
            );
            return s;
        }
        let i = slot as usize % states.len();
        let mut st = states[i];
        let s = f::fmi3FreeFMUState(c, &mut st);
        assert_eq!(
            s,
            FMI3_OK,
            "fmi3FreeFMUState of an own state refused: {:?}",
            take_log()
        );
        assert!(
            st.is_null(),
            "fmi3FreeFMUState did not set the handle to NULL"
        );
        self.insts[k].states.swap_remove(i);
        s
    }

    /// The serialized bytes of `st` (its size asked first), or the status of the failed call.
    unsafe fn bytes_of(&self, k: usize, st: Fmi3FmuState) -> Result<Vec<u8>, Fmi3Status> {
        let c = self.insts[k].c;
        let mut size = usize::MAX;
        let s = f::fmi3SerializedFMUStateSize(c, st, &mut size);
        if s != FMI3_OK {
            return Err(s);
        }
        let mut buf = vec![0u8; size];
        let s = f::fmi3SerializeFMUState(c, st, buf.as_mut_ptr(), size);
        assert_eq!(
            s,
            FMI3_OK,
            "fmi3SerializeFMUState after its size refused: {:?}",
            take_log()
        );
        Ok(buf)
    }

    /// Serialize into an exact (or one byte short) buffer; the exact bytes deserialize into a
    /// state that serializes to the same bytes.
    unsafe fn serialize(&mut self, k: usize, slot: u8, short: bool) {
        let c = self.insts[k].c;
        let st = self.own(k, slot).unwrap_or(std::ptr::null_mut());
        let mut size = 0usize;
        let s = f::fmi3SerializedFMUStateSize(c, st, &mut size);
        self.insts[k].check(s, &"fmi3SerializedFMUStateSize");
        if s != FMI3_OK {
            assert!(
                st.is_null(),
                "fmi3SerializedFMUStateSize of an own state refused"
            );
            return;
        }
        let n = if short { size.saturating_sub(1) } else { size };
        let mut buf = vec![0u8; n.max(1)];
        let s = f::fmi3SerializeFMUState(c, st, buf.as_mut_ptr(), n);
        self.insts[k].check(s, &"fmi3SerializeFMUState");
        if short {
            assert_eq!(
                s, FMI3_ERROR,
                "fmi3SerializeFMUState into a short buffer accepted"
            );
            return;
        }
        assert_eq!(s, FMI3_OK);
        let mut st2: Fmi3FmuState = std::ptr::null_mut();
        let s2 = f::fmi3DeserializeFMUState(c, buf.as_ptr(), n, &mut st2);
        assert_eq!(
            s2,
            FMI3_OK,
            "own serialized state refused: {:?}",
            take_log()
        );
        self.insts[k].states.push(st2);
        let again = self
            .bytes_of(k, st2)
            .expect("deserialized state does not serialize");
        assert_eq!(
            buf[..n],
            again[..],
            "serialize/deserialize round trip differs"
        );
        take_log();
    }

    /// Bytes of a real state (damaged) or random ones, into a new handle or an own one.
    unsafe fn deserialize(&mut self, k: usize, op: &StateOp) -> Fmi3Status {
        let StateOp::Deserialize {
            slot,
            flip,
            truncate,
            ref raw,
            into_own,
        } = *op
        else {
            return FMI3_ERROR;
        };
        let mut bytes = match (raw, self.own(k, slot)) {
            (Some(raw), _) => raw.clone(),
            (None, Some(st)) => self.bytes_of(k, st).expect("own state does not serialize"),
            (None, None) => b"AFMUST01garbage".to_vec(),
        };
        take_log();
        if let (Some((pos, x)), false) = (flip, bytes.is_empty()) {
            let i = pos as usize % bytes.len();
            bytes[i] ^= x;
        }
        if let Some(t) = truncate {
            bytes.truncate(t as usize % (bytes.len() + 1));
        }
        let target = if into_own { self.own(k, slot) } else { None };
        let mut st = target.unwrap_or(std::ptr::null_mut());
        let s = f::fmi3DeserializeFMUState(self.insts[k].c, bytes.as_ptr(), bytes.len(), &mut st);
        if s == FMI3_OK {
            assert!(!st.is_null(), "fmi3DeserializeFMUState gave a NULL state");
            if target.is_some() {
                assert_eq!(
                    Some(st),
                    target,
                    "deserialized into an own state moved the handle"
                );
            } else {
                self.insts[k].states.push(st);
            }
        }
        s
    }
}
