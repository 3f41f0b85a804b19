//! Content models as automata: an element's particle (sequences, choices, multiplicities,
//! wildcards) compiled into a nondeterministic automaton over its children's names (Thompson's
//! construction), which the walk advances child by child. The set of states it is in names the
//! elements allowed next, for a finding, and whether the element may end there.

use super::model::{Elem, Particle, Term};

/// What a transition reads: a declared element or, for `xs:any`, any element.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Label {
    Elem(&'static Elem),
    Any,
}

/// An automaton of one content model; state 0 is the start.
#[derive(Debug, Default)]
pub(crate) struct Automaton {
    epsilon: Vec<Vec<usize>>,
    edges: Vec<Vec<(Label, usize)>>,
    accept: usize,
}

/// Where an automaton is: the sorted set of states, closed under empty transitions.
pub(crate) type States = Vec<usize>;

/// The child an automaton read: the declaration it matched, or a wildcard.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Matched {
    Elem(&'static Elem),
    Any,
}

impl Automaton {
    /// The automaton of `particle`.
    pub(crate) fn new(particle: &Particle) -> Self {
        let mut a = Automaton::default();
        let start = a.state();
        a.accept = a.particle(particle, start);
        a
    }

    fn state(&mut self) -> usize {
        self.epsilon.push(Vec::new());
        self.edges.push(Vec::new());
        self.epsilon.len() - 1
    }

    /// Adds `p` after state `from`; returns the state after it.
    fn particle(&mut self, p: &Particle, from: usize) -> usize {
        let mut at = from;
        for _ in 0..p.min {
            at = self.term(&p.term, at);
        }
        match p.max {
            // zero or more further occurrences: a loop through a state of its own, so that
            // the particles before and after it cannot be re-entered from inside the loop
            None => {
                let again = self.state();
                self.epsilon[at].push(again);
                let end = self.term(&p.term, again);
                self.epsilon[end].push(again);
                let exit = self.state();
                self.epsilon[again].push(exit);
                exit
            }
            Some(max) => {
                for _ in p.min..max {
                    let end = self.term(&p.term, at);
                    self.epsilon[at].push(end);
                    at = end;
                }
                at
            }
        }
    }

    /// Adds one occurrence of `t` after state `from`; returns the state after it.
    fn term(&mut self, t: &Term, from: usize) -> usize {
        match t {
            Term::Elem(e) => self.edge(from, Label::Elem(e)),
            Term::Any => self.edge(from, Label::Any),
            Term::Seq(ps) => ps.iter().fold(from, |at, p| self.particle(p, at)),
            Term::Choice(ps) => {
                let end = self.state();
                for p in ps.iter() {
                    let branch = self.state();
                    self.epsilon[from].push(branch);
                    let after = self.particle(p, branch);
                    self.epsilon[after].push(end);
                }
                end
            }
        }
    }

    fn edge(&mut self, from: usize, label: Label) -> usize {
        let to = self.state();
        self.edges[from].push((label, to));
        to
    }

    /// The states before the first child.
    pub(crate) fn start(&self) -> States {
        self.closure(vec![0])
    }

    fn closure(&self, mut todo: Vec<usize>) -> States {
        let mut seen = vec![false; self.epsilon.len()];
        let mut out = Vec::new();
        while let Some(s) = todo.pop() {
            if !std::mem::replace(&mut seen[s], true) {
                out.push(s);
                todo.extend(&self.epsilon[s]);
            }
        }
        out.sort_unstable();
        out
    }

    /// Reads a child named `name` (`None`: an element in a namespace, which only a wildcard
    /// takes): the states after it and what it matched, or `None` when it is not allowed here.
    /// A declared element is preferred to a wildcard (the schemas never offer both for a name).
    pub(crate) fn step(&self, states: &States, name: Option<&str>) -> Option<(States, Matched)> {
        let mut next = Vec::new();
        let mut matched = None;
        for &s in states {
            for (label, to) in &self.edges[s] {
                let hit = match label {
                    Label::Elem(e) if Some(e.name) == name => Some(Matched::Elem(e)),
                    Label::Any => Some(Matched::Any),
                    Label::Elem(_) => None,
                };
                if let Some(m) = hit {
                    next.push(*to);
                    if !matches!(matched, Some(Matched::Elem(_))) {
                        matched = Some(m);
                    }
                }
            }
        }
        matched.map(|m| (self.closure(next), m))
    }

    /// Whether the element may end in `states`.
    pub(crate) fn accepts(&self, states: &States) -> bool {
        states.binary_search(&self.accept).is_ok()
    }

    /// The children allowed in `states`, in the schema's order, each once (`*` for a wildcard).
    pub(crate) fn expected(&self, states: &States) -> Vec<String> {
        let mut names: Vec<String> = Vec::new();
        for &s in states {
            for (label, _) in &self.edges[s] {
                let n = match label {
                    Label::Elem(e) => format!("<{}>", e.name),
                    Label::Any => "any element".to_string(),
                };
                if !names.contains(&n) {
                    names.push(n);
                }
            }
        }
        names
    }

    /// The declaration of a child named `name` anywhere in this content model, for checking a
    /// child that is out of place.
    pub(crate) fn declared(&self, name: &str) -> Option<&'static Elem> {
        self.edges
            .iter()
            .flatten()
            .find_map(|(label, _)| match label {
                Label::Elem(e) if e.name == name => Some(*e),
                _ => None,
            })
    }
}
