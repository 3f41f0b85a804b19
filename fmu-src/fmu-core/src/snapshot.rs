//! FMU-state snapshots: everything needed to continue a simulation bit-identically, and their
//! serialized form (a header naming the format and the model's GUID, the bincode payload, a
//! checksum).

use crate::instance::Instance;
use crate::machine::MachineState;
use crate::Model;
use bincode::Options as _;
use serde::{Deserialize, Serialize};

/// Everything needed to continue a simulation bit-identically: getting an FMU state copies it,
/// serializing writes it with bincode behind a header naming the model and GUID.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(bound = "")]
pub struct Snapshot<M: Model> {
    pub(crate) state: MachineState,
    pub(crate) time: f64,
    pub(crate) start_time: f64,
    pub(crate) stop_time: Option<f64>,
    pub(crate) tolerance: Option<f64>,
    pub(crate) vars: Vec<f64>,
    pub(crate) model: M,
}

/// Format of serialized FMU states: a new layout gets a new number.
const SERIAL_MAGIC: &[u8; 8] = b"AFMUST03";

/// Fixed-width little-endian encoding: f64 values are written bit for bit.
fn bincode_options() -> impl bincode::Options {
    use bincode::Options;
    bincode::DefaultOptions::new()
        .with_fixint_encoding()
        .with_little_endian()
}

impl<M: Model> Instance<M> {
    /// Bytes of a serialized FMU state: the format magic, the GUID (length-prefixed), the
    /// payload length, the bincode snapshot, and a checksum of everything before it.
    pub fn serialize(&self, s: &Snapshot<M>) -> Result<Vec<u8>, StateError> {
        let mut out = Vec::with_capacity(256);
        out.extend_from_slice(SERIAL_MAGIC);
        let guid = self.guid.as_bytes();
        out.extend_from_slice(&(guid.len() as u32).to_le_bytes());
        out.extend_from_slice(guid);
        let payload = bincode_options()
            .serialize(s)
            .map_err(|e| StateError::Encode(e.to_string()))?;
        out.extend_from_slice(&(payload.len() as u64).to_le_bytes());
        out.extend_from_slice(&payload);
        let sum = checksum(&out);
        out.extend_from_slice(&sum);
        Ok(out)
    }

    /// Inverse of [`Instance::serialize`]: refuses bytes of another format or model, a length
    /// that does not match, and any change the checksum detects, before decoding anything.
    pub fn deserialize(&self, bytes: &[u8]) -> Result<Snapshot<M>, StateError> {
        if !bytes.starts_with(SERIAL_MAGIC) {
            return Err(StateError::BadHeader);
        }
        let (body, sum) = bytes
            .split_last_chunk::<CHECKSUM_LEN>()
            .filter(|(body, _)| body.len() >= SERIAL_MAGIC.len())
            .ok_or(StateError::Truncated(bytes.len()))?;
        let rest = &body[SERIAL_MAGIC.len()..];
        if checksum(body) != *sum {
            return Err(StateError::Checksum);
        }
        let (n, rest) = rest
            .split_first_chunk::<4>()
            .ok_or(StateError::Truncated(bytes.len()))?;
        let (guid, rest) = rest
            .split_at_checked(u32::from_le_bytes(*n) as usize)
            .ok_or(StateError::Truncated(bytes.len()))?;
        if guid != self.guid.as_bytes() {
            return Err(StateError::OtherModel);
        }
        let (len, payload) = rest
            .split_first_chunk::<8>()
            .ok_or(StateError::Truncated(bytes.len()))?;
        if u64::from_le_bytes(*len) != payload.len() as u64 {
            return Err(StateError::Truncated(bytes.len()));
        }
        let s: Snapshot<M> = bincode_options()
            .with_limit(payload.len() as u64)
            .deserialize(payload)
            .map_err(|e| StateError::Decode(e.to_string()))?;
        if s.vars.len() != M::variables().len() {
            return Err(StateError::Decode(format!(
                "{} variables, the model has {}",
                s.vars.len(),
                M::variables().len()
            )));
        }
        Ok(s)
    }
}

/// Length of the checksum closing a serialized FMU state.
const CHECKSUM_LEN: usize = 8;

/// The first 8 bytes of SHA-256 (already linked for the GUID): any change of a serialized state
/// (a flipped bit, a truncated or spliced buffer) is refused before decoding, rather than
/// decoded into a state that is valid bincode but not the one saved.
fn checksum(bytes: &[u8]) -> [u8; CHECKSUM_LEN] {
    use sha2::{Digest, Sha256};
    let d = Sha256::digest(bytes);
    let mut out = [0; CHECKSUM_LEN];
    out.copy_from_slice(&d[..CHECKSUM_LEN]);
    out
}

/// Why a serialized FMU state was refused (or could not be written).
#[derive(Debug, thiserror::Error)]
pub enum StateError {
    #[error("not a serialized FMU state of this FMU (bad header)")]
    BadHeader,
    #[error("serialized FMU state is truncated or its length field is wrong ({0} bytes)")]
    Truncated(usize),
    #[error("serialized FMU state is damaged (checksum mismatch)")]
    Checksum,
    #[error("serialized FMU state belongs to another model (GUID differs)")]
    OtherModel,
    #[error("serialized FMU state cannot be decoded: {0}")]
    Decode(String),
    #[error("FMU state cannot be serialized: {0}")]
    Encode(String),
}
