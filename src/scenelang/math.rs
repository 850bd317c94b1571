//! `$ … $` math expressions: a small, safe evaluator (no code execution) with Julia's
//! precedence, which is what Raytracer.jl scripts were written against.
//!
//! Grammar, loosest binding first:
//! ```text
//! expr    := term (('+' | '-') term)*
//! term    := unary (('*' | '/' | '%') unary)*
//! unary   := ('-' | '+') unary | juxt
//! juxt    := NUMBER (IDENT | '(') …   → NUMBER * power   (juxtaposition: `2a`, `2(a+1)`, `2a^2` = 2·a²)
//!          | power
//! power   := primary ('^' unary)?      (right-associative: 2^3^2 = 2^9; 2^-1 allowed; -2^2 = -4)
//! primary := NUMBER | IDENT | IDENT '(' expr (',' expr)* ')' | '(' expr ')'
//! ```
//! Functions: `floor ceil round exp exp2 exp10 log log2 log10 log1p sin cos tan asin acos`
//! (one argument), `atan` (one or two), `div` (two: truncated division, like Julia's `div`),
//! `Point(x, y, z)`, `RGB(r, g, b)`; **ext**: `sqrt`, `abs`. `round` rounds half to even like
//! Julia. Names: variables bound to numbers, colours or points, `TIME`, and **ext** `pi`.
//! Every intermediate result must be finite.

use glam::DVec3;

use super::error::{ErrorKind, Span};
use super::value::Ty;
use crate::color::Color;

/// The value of a math expression.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum MathValue {
    /// A plain number.
    Num(f64),
    /// A linear RGB colour (`RGB(r, g, b)`, or a variable holding a colour).
    Color(Color),
    /// A point or vector (`Point(x, y, z)`, or a variable holding a point).
    Point(DVec3),
}

impl MathValue {
    fn kind(&self) -> &'static str {
        match self {
            MathValue::Num(_) => "number",
            MathValue::Color(_) => "colour",
            MathValue::Point(_) => "point",
        }
    }
    fn is_finite(&self) -> bool {
        match self {
            MathValue::Num(v) => v.is_finite(),
            MathValue::Color(c) => c.is_finite(),
            MathValue::Point(p) => p.is_finite(),
        }
    }
}

/// What a name means inside an expression.
pub enum Lookup {
    /// Bound to a number, colour or point, which the expression uses.
    Value(MathValue),
    /// Defined, but of a type expressions cannot use.
    WrongType(Ty),
    /// Not bound to anything; `TIME`, `pi` and `π` then fall back to their built-in values.
    Undefined,
}

/// An error inside an expression, with its absolute span in the script.
#[derive(Debug, Clone, PartialEq)]
pub struct MathError {
    /// The culprit's bytes in the whole script (not in the expression's text).
    pub span: Span,
    /// The class of error the caller reports (`BadExpression`, `UndefinedName`, …).
    pub kind: ErrorKind,
    /// The one-line description of what is wrong.
    pub message: String,
    /// What would have been accepted there, for the diagnostic's `expected:` line.
    pub expected: Option<String>,
}

fn err(span: Span, kind: ErrorKind, message: impl Into<String>) -> MathError {
    MathError { span, kind, message: message.into(), expected: None }
}

#[derive(Debug, Clone, PartialEq)]
enum M {
    Num(f64),
    Ident(String),
    Op(char),
}

struct Tok {
    t: M,
    span: Span,
}

const MAX_DEPTH: usize = 200;

const FUNCTIONS: [&str; 21] = [
    "floor", "ceil", "round", "exp", "exp2", "exp10", "log", "log2", "log10", "log1p", "sin", "cos", "tan", "asin",
    "acos", "atan", "div", "Point", "RGB", "sqrt", "abs",
];

/// Evaluates `text`, which starts at byte `offset` of the script, looking names up with `lookup`.
///
/// ```
/// use lumen::scenelang::math::{evaluate, Lookup, MathValue};
/// let a = |name: &str| if name == "a" { Lookup::Value(MathValue::Num(9.0)) } else { Lookup::Undefined };
/// assert_eq!(evaluate("1 + 2a", 0, 0.0, &a).unwrap(), MathValue::Num(19.0));
/// ```
pub fn evaluate(text: &str, offset: usize, time: f64, lookup: &dyn Fn(&str) -> Lookup) -> Result<MathValue, MathError> {
    let toks = tokenize(text, offset)?;
    if toks.is_empty() {
        return Err(MathError {
            expected: Some("a number, a name or a function call between the `$` signs".into()),
            ..err(
                Span::new(offset.saturating_sub(1), text.len() + 2),
                ErrorKind::BadExpression,
                "empty math expression",
            )
        });
    }
    let mut p = Parser { toks, i: 0, end: offset + text.len(), time, lookup, depth: 0 };
    let (v, _) = p.expr()?;
    if let Some(t) = p.toks.get(p.i) {
        let after_number = p.i > 0 && matches!(p.toks[p.i - 1].t, M::Num(_));
        let hint = if after_number && matches!(t.t, M::Ident(_) | M::Op('(')) {
            " (juxtaposition is written without a space, as in `2a`)"
        } else {
            ""
        };
        return Err(MathError {
            expected: Some(format!("an operator (+ - * / % ^) or the closing `$`{hint}")),
            ..err(t.span, ErrorKind::BadExpression, format!("unexpected {} in math expression", show(&t.t)))
        });
    }
    Ok(v)
}

/// A value that is not finite, as an error message says it: `infinity`, `NaN`, or the
/// colour or point in SceneLang's syntax (`<inf, 0, 1>`, `{NaN, 0, 0}`).
fn non_finite_text(v: &MathValue) -> String {
    match *v {
        MathValue::Num(x) if x.is_nan() => "NaN".into(),
        MathValue::Num(x) => (if x > 0.0 { "infinity" } else { "minus infinity" }).into(),
        MathValue::Color(c) => format!("the colour {}", super::dump::describe(&super::value::Value::Color(c))),
        MathValue::Point(p) => format!("the point {}", super::dump::describe(&super::value::Value::Point(p))),
    }
}

fn show(t: &M) -> String {
    match t {
        M::Num(n) => format!("number `{n}`"),
        M::Ident(i) => format!("`{i}`"),
        M::Op(c) => format!("`{c}`"),
    }
}

fn tokenize(text: &str, offset: usize) -> Result<Vec<Tok>, MathError> {
    let b = text.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < text.len() {
        let c = text[i..].chars().next().expect("in bounds");
        let start = i;
        if c.is_whitespace() {
            i += c.len_utf8();
            continue;
        }
        if c.is_ascii_digit() || (c == '.' && b.get(i + 1).is_some_and(u8::is_ascii_digit)) {
            while i < b.len() && b[i].is_ascii_digit() {
                i += 1;
            }
            if i < b.len() && b[i] == b'.' {
                i += 1;
                while i < b.len() && b[i].is_ascii_digit() {
                    i += 1;
                }
            }
            if i < b.len() && (b[i] == b'e' || b[i] == b'E') {
                let mut j = i + 1;
                if j < b.len() && (b[j] == b'+' || b[j] == b'-') {
                    j += 1;
                }
                if j < b.len() && b[j].is_ascii_digit() {
                    i = j;
                    while i < b.len() && b[i].is_ascii_digit() {
                        i += 1;
                    }
                }
            }
            let span = Span::new(offset + start, i - start);
            let v: f64 = text[start..i].parse().map_err(|_| MathError {
                expected: Some("a number such as `1`, `1.5` or `2e-3`".into()),
                ..err(span, ErrorKind::BadNumber, format!("bad number `{}` in math expression", &text[start..i]))
            })?;
            if !v.is_finite() {
                return Err(MathError {
                    expected: Some(super::lexer::FINITE_NUMBER.into()),
                    ..err(span, ErrorKind::BadNumber, format!("number `{}` is out of range", &text[start..i]))
                });
            }
            out.push(Tok { t: M::Num(v), span });
        } else if c.is_alphabetic() || c == '_' {
            while let Some(ch) = text[i..].chars().next() {
                if ch.is_alphanumeric() || ch == '_' {
                    i += ch.len_utf8();
                } else {
                    break;
                }
            }
            out.push(Tok { t: M::Ident(text[start..i].to_string()), span: Span::new(offset + start, i - start) });
        } else if "+-*/%^(),".contains(c) {
            i += 1;
            out.push(Tok { t: M::Op(c), span: Span::new(offset + start, 1) });
        } else {
            return Err(MathError {
                expected: Some("numbers, names, + - * / % ^ ( ) , and function calls".into()),
                ..err(
                    Span::new(offset + start, c.len_utf8()),
                    ErrorKind::BadExpression,
                    format!("unexpected character `{c}` in math expression"),
                )
            });
        }
    }
    Ok(out)
}

struct Parser<'a> {
    toks: Vec<Tok>,
    i: usize,
    end: usize,
    time: f64,
    lookup: &'a dyn Fn(&str) -> Lookup,
    depth: usize,
}

type R = Result<(MathValue, Span), MathError>;

impl Parser<'_> {
    fn peek_op(&self) -> Option<char> {
        match self.toks.get(self.i) {
            Some(Tok { t: M::Op(c), .. }) => Some(*c),
            _ => None,
        }
    }
    fn end_span(&self) -> Span {
        Span::new(self.end, 1)
    }

    fn finite(&self, v: MathValue, span: Span) -> R {
        if v.is_finite() {
            Ok((v, span))
        } else {
            Err(MathError {
                expected: Some("a finite result (check for division by zero or a function outside its domain)".into()),
                ..err(
                    span,
                    ErrorKind::NonFinite,
                    format!("math expression gives a non-finite value: {}", non_finite_text(&v)),
                )
            })
        }
    }

    fn enter(&mut self, span: Span) -> Result<(), MathError> {
        self.depth += 1;
        if self.depth > MAX_DEPTH {
            return Err(MathError {
                expected: Some("a flatter expression (SET intermediate values)".into()),
                ..err(span, ErrorKind::TooDeep, format!("math expression nested deeper than {MAX_DEPTH} levels"))
            });
        }
        Ok(())
    }

    fn expr(&mut self) -> R {
        let (mut v, mut s) = self.term()?;
        while let Some(op @ ('+' | '-')) = self.peek_op() {
            let op_span = self.toks[self.i].span;
            self.i += 1;
            let (w, ws) = self.term()?;
            let r = binary(op, v, w, op_span)?;
            (v, s) = self.finite(r, s.to(ws))?;
        }
        Ok((v, s))
    }

    fn term(&mut self) -> R {
        let (mut v, mut s) = self.unary()?;
        while let Some(op @ ('*' | '/' | '%')) = self.peek_op() {
            let op_span = self.toks[self.i].span;
            self.i += 1;
            let (w, ws) = self.unary()?;
            let r = binary(op, v, w, op_span)?;
            (v, s) = self.finite(r, s.to(ws))?;
        }
        Ok((v, s))
    }

    fn unary(&mut self) -> R {
        match self.peek_op() {
            Some(op @ ('-' | '+')) => {
                let span = self.toks[self.i].span;
                self.enter(span)?;
                self.i += 1;
                let (v, s) = self.unary()?;
                self.depth -= 1;
                let r = if op == '-' { negate(v) } else { v };
                Ok((r, span.to(s)))
            }
            _ => self.juxt(),
        }
    }

    fn juxt(&mut self) -> R {
        if let (Some(Tok { t: M::Num(n), span }), Some(next)) = (self.toks.get(self.i), self.toks.get(self.i + 1)) {
            let adjacent = next.span.start == span.start + span.len;
            if adjacent && matches!(next.t, M::Ident(_) | M::Op('(')) {
                let (n, span) = (*n, *span);
                self.i += 1;
                let (v, s) = self.power()?;
                let r = binary('*', MathValue::Num(n), v, span)?;
                return self.finite(r, span.to(s));
            }
        }
        self.power()
    }

    fn power(&mut self) -> R {
        let (v, s) = self.primary()?;
        if self.peek_op() == Some('^') {
            let op_span = self.toks[self.i].span;
            self.enter(op_span)?;
            self.i += 1;
            let (w, ws) = self.unary()?;
            self.depth -= 1;
            let r = binary('^', v, w, op_span)?;
            return self.finite(r, s.to(ws));
        }
        Ok((v, s))
    }

    fn primary(&mut self) -> R {
        let Some(tok) = self.toks.get(self.i) else {
            return Err(MathError {
                expected: Some("a number, a name, a function call or `(`".into()),
                ..err(self.end_span(), ErrorKind::BadExpression, "math expression ends too early")
            });
        };
        let span = tok.span;
        match tok.t.clone() {
            M::Num(n) => {
                self.i += 1;
                Ok((MathValue::Num(n), span))
            }
            M::Op('(') => {
                self.enter(span)?;
                self.i += 1;
                let (v, _) = self.expr()?;
                let close = self.expect_close(span)?;
                self.depth -= 1;
                Ok((v, span.to(close)))
            }
            M::Op(c) => Err(MathError {
                expected: Some("a number, a name, a function call or `(`".into()),
                ..err(span, ErrorKind::BadExpression, format!("unexpected `{c}` in math expression"))
            }),
            M::Ident(name) => {
                self.i += 1;
                if self.peek_op() == Some('(') {
                    return self.call(&name, span);
                }
                if FUNCTIONS.contains(&name.as_str()) {
                    return Err(MathError {
                        expected: Some(format!("arguments in parentheses, as in `{name}(x)`")),
                        ..err(span, ErrorKind::BadExpression, format!("function `{name}` used without arguments"))
                    });
                }
                match (self.lookup)(&name) {
                    Lookup::Value(v) => Ok((v, span)),
                    Lookup::WrongType(ty) => Err(MathError {
                        expected: Some("a variable holding a number, a colour or a point".into()),
                        ..err(
                            span,
                            ErrorKind::WrongType,
                            format!("variable `{name}` holds {} and cannot be used in a math expression", ty.article()),
                        )
                    }),
                    Lookup::Undefined if name == "TIME" => Ok((MathValue::Num(self.time), span)),
                    Lookup::Undefined if name == "pi" || name == "π" => {
                        Ok((MathValue::Num(std::f64::consts::PI), span))
                    }
                    Lookup::Undefined => Err(MathError {
                        expected: Some("a variable defined with SET (or --vars) before this line".into()),
                        ..err(
                            span,
                            ErrorKind::UndefinedName,
                            format!("undefined identifier `{name}` in math expression"),
                        )
                    }),
                }
            }
        }
    }

    fn expect_close(&mut self, open: Span) -> Result<Span, MathError> {
        match self.toks.get(self.i) {
            Some(Tok { t: M::Op(')'), span }) => {
                self.i += 1;
                Ok(*span)
            }
            Some(t) => Err(MathError {
                expected: Some("`)`".into()),
                ..err(t.span, ErrorKind::BadExpression, format!("unexpected {} in math expression", show(&t.t)))
            }),
            None => Err(MathError {
                expected: Some("`)`".into()),
                ..err(open, ErrorKind::BadExpression, "unclosed `(` in math expression")
            }),
        }
    }

    fn call(&mut self, name: &str, name_span: Span) -> R {
        let open = self.toks[self.i].span;
        self.enter(open)?;
        self.i += 1;
        let mut args = Vec::new();
        if self.peek_op() != Some(')') {
            loop {
                args.push(self.expr()?);
                if self.peek_op() == Some(',') {
                    self.i += 1;
                } else {
                    break;
                }
            }
        }
        let close = self.expect_close(open)?;
        self.depth -= 1;
        let span = name_span.to(close);
        let arity = |ok: &[usize]| -> Result<(), MathError> {
            if ok.contains(&args.len()) {
                Ok(())
            } else {
                let want = ok.iter().map(usize::to_string).collect::<Vec<_>>().join(" or ");
                Err(MathError {
                    expected: Some(format!("{want} argument{}", if ok == [1] { "" } else { "s" })),
                    ..err(
                        span,
                        ErrorKind::BadExpression,
                        format!(
                            "`{name}` takes {want} argument{}, got {}",
                            if ok == [1] { "" } else { "s" },
                            args.len()
                        ),
                    )
                })
            }
        };
        let num = |k: usize| -> Result<f64, MathError> {
            match args[k].0 {
                MathValue::Num(v) => Ok(v),
                other => Err(MathError {
                    expected: Some("a number".into()),
                    ..err(
                        args[k].1,
                        ErrorKind::WrongType,
                        format!("argument {} of `{name}` is a {}", k + 1, other.kind()),
                    )
                }),
            }
        };
        let v = match name {
            "Point" | "RGB" => {
                arity(&[3])?;
                let (a, b, c) = (num(0)?, num(1)?, num(2)?);
                if name == "Point" {
                    MathValue::Point(DVec3::new(a, b, c))
                } else {
                    MathValue::Color(Color::new(a, b, c))
                }
            }
            "atan" => {
                arity(&[1, 2])?;
                if args.len() == 2 {
                    MathValue::Num(num(0)?.atan2(num(1)?))
                } else {
                    MathValue::Num(num(0)?.atan())
                }
            }
            "div" => {
                arity(&[2])?;
                MathValue::Num((num(0)? / num(1)?).trunc())
            }
            _ => {
                let f: fn(f64) -> f64 = match name {
                    "floor" => f64::floor,
                    "ceil" => f64::ceil,
                    "round" => f64::round_ties_even,
                    "exp" => f64::exp,
                    "exp2" => f64::exp2,
                    "exp10" => |x| 10f64.powf(x),
                    "log" => f64::ln,
                    "log2" => f64::log2,
                    "log10" => f64::log10,
                    "log1p" => f64::ln_1p,
                    "sin" => f64::sin,
                    "cos" => f64::cos,
                    "tan" => f64::tan,
                    "asin" => f64::asin,
                    "acos" => f64::acos,
                    "sqrt" => f64::sqrt,
                    "abs" => f64::abs,
                    _ => {
                        return Err(MathError {
                            expected: Some(format!("one of {}", FUNCTIONS.join(" "))),
                            ..err(name_span, ErrorKind::BadExpression, format!("unknown function `{name}`"))
                        })
                    }
                };
                arity(&[1])?;
                MathValue::Num(f(num(0)?))
            }
        };
        self.finite(v, span)
    }
}

fn negate(v: MathValue) -> MathValue {
    match v {
        MathValue::Num(a) => MathValue::Num(-a),
        MathValue::Color(c) => MathValue::Color(c * -1.0),
        MathValue::Point(p) => MathValue::Point(-p),
    }
}

fn binary(op: char, a: MathValue, b: MathValue, op_span: Span) -> Result<MathValue, MathError> {
    use MathValue::*;
    let r = match (op, a, b) {
        ('+', Num(x), Num(y)) => Num(x + y),
        ('-', Num(x), Num(y)) => Num(x - y),
        ('*', Num(x), Num(y)) => Num(x * y),
        ('/', Num(x), Num(y)) => Num(x / y),
        ('%', Num(x), Num(y)) => Num(x % y),
        ('^', Num(x), Num(y)) => Num(x.powf(y)),
        ('+', Color(x), Color(y)) => Color(x + y),
        ('-', Color(x), Color(y)) => Color(x - y),
        ('*', Color(x), Num(y)) | ('*', Num(y), Color(x)) => Color(x * y),
        ('/', Color(x), Num(y)) => Color(x / y),
        ('+', Point(x), Point(y)) => Point(x + y),
        ('-', Point(x), Point(y)) => Point(x - y),
        ('*', Point(x), Num(y)) | ('*', Num(y), Point(x)) => Point(x * y),
        ('/', Point(x), Num(y)) => Point(x / y),
        _ => return Err(MathError {
            expected: Some(
                "numbers with any operator; colours or points added, subtracted, or multiplied and divided by numbers"
                    .into(),
            ),
            ..err(op_span, ErrorKind::WrongType, format!("cannot apply `{op}` to a {} and a {}", a.kind(), b.kind()))
        }),
    };
    Ok(r)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn vars(name: &str) -> Lookup {
        match name {
            "a" => Lookup::Value(MathValue::Num(9.0)),
            "x" => Lookup::Value(MathValue::Num(2.0)),
            "white" => Lookup::Value(MathValue::Color(Color::WHITE)),
            "p" => Lookup::Value(MathValue::Point(DVec3::new(1.0, 2.0, 3.0))),
            "m" => Lookup::WrongType(Ty::Material),
            _ => Lookup::Undefined,
        }
    }
    fn ev(s: &str) -> Result<MathValue, MathError> {
        evaluate(s, 0, 1.5, &vars)
    }
    fn num(s: &str) -> f64 {
        match ev(s).unwrap() {
            MathValue::Num(v) => v,
            other => panic!("{s}: {other:?}"),
        }
    }

    #[test]
    fn precedence_like_julia() {
        assert_eq!(num("1 + 2 * 3"), 7.0);
        assert_eq!(num("(1 + 2) * 3"), 9.0);
        assert_eq!(num("-2^2"), -4.0);
        assert_eq!(num("2^3^2"), 512.0);
        assert_eq!(num("2^-1"), 0.5);
        assert_eq!(num("7 - 2 - 1"), 4.0);
        assert_eq!(num("8 / 2 / 2"), 2.0);
        assert_eq!(num("-7 % 3"), -1.0);
        assert_eq!(num("2 * -3"), -6.0);
    }

    #[test]
    fn juxtaposition() {
        assert_eq!(num("1 + 2a"), 19.0);
        assert_eq!(num("2a^2"), 162.0);
        assert_eq!(num("2(x + 1)"), 6.0);
        assert_eq!(num("1/2x"), 0.25);
        assert_eq!(num("3sin(0)"), 0.0);
        // With a space it is not juxtaposition, and the error says so.
        let e = ev("2 a").unwrap_err();
        assert_eq!((e.kind, e.span), (ErrorKind::BadExpression, Span::new(2, 1)));
        assert!(e.expected.unwrap().contains("without a space"));
    }

    #[test]
    fn functions() {
        assert_eq!(num("floor(-1.5) + ceil(1.2) + round(2.5) + round(3.5)"), -2.0 + 2.0 + 2.0 + 4.0);
        assert_eq!(num("div(7, 2)"), 3.0);
        assert_eq!(num("div(-7, 2)"), -3.0);
        assert!((num("exp(1)") - std::f64::consts::E).abs() < 1e-15);
        assert_eq!(num("exp2(3) + exp10(2) + log2(8) + log10(1000)"), 8.0 + 100.0 + 3.0 + 3.0);
        assert!((num("log(exp(2)) + log1p(0)") - 2.0).abs() < 1e-15);
        assert!((num("sin(pi/2) + cos(0) + tan(0)") - 2.0).abs() < 1e-15);
        assert!((num("asin(1) + acos(1)") - std::f64::consts::FRAC_PI_2).abs() < 1e-15);
        assert!((num("atan(1, 1) - atan(1)")).abs() < 1e-15);
        assert_eq!(num("atan(0, -1)"), std::f64::consts::PI);
        assert_eq!(num("TIME * 2"), 3.0);
        assert_eq!(num("sqrt(16) + abs(-1)"), 5.0);
    }

    #[test]
    fn colours_and_points() {
        assert_eq!(ev("white * 0.05").unwrap(), MathValue::Color(Color::gray(0.05)));
        assert_eq!(ev("2 * RGB(1, 2, 3) + white").unwrap(), MathValue::Color(Color::new(3.0, 5.0, 7.0)));
        assert_eq!(ev("p / 2 - Point(0, 1, 0)").unwrap(), MathValue::Point(DVec3::new(0.5, 0.0, 1.5)));
        assert_eq!(ev("-p").unwrap(), MathValue::Point(DVec3::new(-1.0, -2.0, -3.0)));
        assert_eq!(ev("white + p").unwrap_err().kind, ErrorKind::WrongType);
        assert_eq!(ev("white * white").unwrap_err().kind, ErrorKind::WrongType);
        assert_eq!(ev("sin(p)").unwrap_err().kind, ErrorKind::WrongType);
    }

    #[test]
    fn errors_are_located() {
        let e = evaluate("1 + 2b", 10, 0.0, &vars).unwrap_err();
        assert_eq!((e.kind, e.span), (ErrorKind::UndefinedName, Span::new(15, 1)));
        let e = ev("1/0").unwrap_err();
        assert_eq!((e.kind, e.span), (ErrorKind::NonFinite, Span::new(0, 3)));
        assert_eq!(ev("log(-1)").unwrap_err().kind, ErrorKind::NonFinite);
        assert_eq!(ev("div(1, 2, 3)").unwrap_err().kind, ErrorKind::BadExpression);
        assert_eq!(ev("atan()").unwrap_err().kind, ErrorKind::BadExpression);
        assert_eq!(ev("foo(1)").unwrap_err().kind, ErrorKind::BadExpression);
        assert_eq!(ev("m + 1").unwrap_err().kind, ErrorKind::WrongType);
        assert_eq!(ev("").unwrap_err().kind, ErrorKind::BadExpression);
        assert_eq!(ev("(1 + 2").unwrap_err().kind, ErrorKind::BadExpression);
        assert_eq!(ev("1 +").unwrap_err().kind, ErrorKind::BadExpression);
        assert_eq!(ev("1 @ 2").unwrap_err().kind, ErrorKind::BadExpression);
        assert_eq!(ev("sin").unwrap_err().kind, ErrorKind::BadExpression);
        assert_eq!(ev(&"(".repeat(1000)).unwrap_err().kind, ErrorKind::TooDeep);
        assert_eq!(ev(&"-".repeat(1000)).unwrap_err().kind, ErrorKind::TooDeep);
        assert_eq!(ev("1e400").unwrap_err().kind, ErrorKind::BadNumber);
    }
}
