//! What travels between ranks, as flat runs of 64-bit words: a body's record (its id and its
//! whole state, bit for bit) and a contact named by global ids. Floats travel as their bits, so nothing is rounded on the way.
//!
//! It owns the layouts and nothing else: it never decides what is sent where.

use glam::DVec3;
use vadop::{BodyHandle, Contact, Rest, SphereRecord, Touched, Wall};

/// Words per body on the wire.
pub const BODY_WORDS: usize = 15;
/// Words per contact on the wire.
pub const CONTACT_WORDS: usize = 11;

/// A body on the wire: its global id (its handle's number in the one-process world) and its
/// state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Parcel {
    pub id: BodyHandle,
    pub record: SphereRecord,
}

fn push_vector(out: &mut Vec<u64>, v: DVec3) {
    out.extend(v.to_array().map(f64::to_bits));
}

fn vector(words: &[u64]) -> DVec3 {
    DVec3::new(f64::from_bits(words[0]), f64::from_bits(words[1]), f64::from_bits(words[2]))
}

impl Parcel {
    pub fn encode(&self, out: &mut Vec<u64>) {
        let r = &self.record;
        out.push(self.id.to_bits());
        push_vector(out, r.position);
        out.push(r.since.to_bits());
        push_vector(out, r.velocity);
        out.push(r.radius.to_bits());
        out.push(r.mass.to_bits());
        // A last contact is finite: minus infinity stands for none.
        out.push(r.last_contact.unwrap_or(f64::NEG_INFINITY).to_bits());
        out.extend(r.crossings.map(|c| c as u64));
        out.push(match r.rest {
            Rest::Falling => 0,
            Rest::Still => 1,
            Rest::Sliding(axes) => 2 | (axes as u64) << 8,
        });
    }

    pub fn decode(words: &[u64]) -> Parcel {
        let last = f64::from_bits(words[10]);
        Parcel {
            id: BodyHandle::from_bits(words[0]),
            record: SphereRecord {
                position: vector(&words[1..4]),
                since: f64::from_bits(words[4]),
                velocity: vector(&words[5..8]),
                radius: f64::from_bits(words[8]),
                mass: f64::from_bits(words[9]),
                last_contact: last.is_finite().then_some(last),
                crossings: [words[11] as i64, words[12] as i64, words[13] as i64],
                rest: match words[14] & 0xff {
                    0 => Rest::Falling,
                    1 => Rest::Still,
                    _ => Rest::Sliding((words[14] >> 8) as u8),
                },
            },
        }
    }
}

/// Writes `contact` (its bodies already named by global ids).
pub fn encode_contact(contact: &Contact, out: &mut Vec<u64>) {
    out.push(contact.time.to_bits());
    out.push(contact.body.to_bits());
    match contact.touched {
        Touched::Body(other) => out.extend([0, other.to_bits()]),
        Touched::Wall(wall) => out.extend([1, wall as u64]),
    }
    push_vector(out, contact.point);
    push_vector(out, contact.normal);
    out.push(contact.impulse.to_bits());
}

pub fn decode_contact(words: &[u64]) -> Contact {
    let touched = match words[2] {
        0 => Touched::Body(BodyHandle::from_bits(words[3])),
        _ => Touched::Wall(Wall::ALL[words[3] as usize]),
    };
    Contact {
        time: f64::from_bits(words[0]),
        body: BodyHandle::from_bits(words[1]),
        touched,
        point: vector(&words[4..7]),
        normal: vector(&words[7..10]),
        impulse: f64::from_bits(words[10]),
    }
}

/// The one-process world's order of a frame's contacts: time, then the body's slot, then what it
/// touched (bodies by slot before walls), as its event queue pops them.
pub fn contact_order(a: &Contact, b: &Contact) -> std::cmp::Ordering {
    let partner = |c: &Contact| match c.touched {
        Touched::Body(other) => (0u8, other.index()),
        Touched::Wall(wall) => (1u8, wall as u32),
    };
    a.time.total_cmp(&b.time).then(a.body.index().cmp(&b.body.index())).then(partner(a).cmp(&partner(b)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bodies_and_contacts_cross_the_wire_bit_for_bit() {
        let record = SphereRecord {
            position: DVec3::new(0.1, -0.0, 3.0),
            since: 1.0 / 3.0,
            velocity: DVec3::new(f64::MIN_POSITIVE, -2.5, 1e300),
            radius: 0.5,
            mass: 0.523,
            last_contact: Some(0.25),
            crossings: [0, -3, 7],
            rest: Rest::Falling,
        };
        for (last, rest) in [(Some(0.25), Rest::Sliding(5)), (None, Rest::Still), (None, Rest::Falling)] {
            let parcel = Parcel {
                id: BodyHandle::from_bits(5 + (2 << 32)),
                record: SphereRecord { last_contact: last, rest, ..record },
            };
            let mut words = Vec::new();
            parcel.encode(&mut words);
            assert_eq!(words.len(), BODY_WORDS);
            let back = Parcel::decode(&words);
            assert_eq!(back, parcel);
            assert_eq!(back.record.position.y.to_bits(), (-0.0f64).to_bits());
        }
        for touched in [Touched::Body(BodyHandle::from_bits(9)), Touched::Wall(Wall::MaxZ)] {
            let contact = Contact {
                time: 0.1,
                body: BodyHandle::from_bits(3),
                touched,
                point: DVec3::new(1.0, 2.0, 3.0),
                normal: DVec3::new(0.0, -1.0, 0.0),
                impulse: 2.0,
            };
            let mut words = Vec::new();
            encode_contact(&contact, &mut words);
            assert_eq!(words.len(), CONTACT_WORDS);
            assert_eq!(decode_contact(&words), contact);
        }
    }
}
