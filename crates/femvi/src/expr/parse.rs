//! Tokenizer and recursive-descent parser of expressions into a postfix list of items (no
//! syntax tree, so nothing downstream recurses). Precedence, loosest first: `+ -`; `* /`;
//! unary minus; `^` (right associative), so `-x^2 = -(x^2)` and `2^-1 = 0.5`. Nesting is
//! limited to [`MAX_NESTING`] levels, which bounds the parser's recursion.

/// An error in an expression, with its position (1-based line and column, in characters).
#[derive(Debug, Clone, PartialEq)]
pub struct ExprError {
    /// What is wrong.
    pub message: String,
    /// Byte offset in the source.
    pub offset: usize,
    /// Line, from 1.
    pub line: usize,
    /// Column, from 1, counted in characters.
    pub column: usize,
    /// The offending source line.
    pub source_line: String,
}

impl ExprError {
    pub(crate) fn at(source: &str, offset: usize, message: impl Into<String>) -> Self {
        let mut offset = offset.min(source.len());
        while !source.is_char_boundary(offset) {
            offset -= 1;
        }
        let before = &source[..offset];
        let line = before.matches('\n').count() + 1;
        let line_start = before.rfind('\n').map_or(0, |i| i + 1);
        let column = source[line_start..offset].chars().count() + 1;
        let source_line = source[line_start..].lines().next().unwrap_or("").to_string();
        Self {
            message: message.into(),
            offset,
            line,
            column,
            source_line,
        }
    }

    /// The message with the source line and a caret under the offending character.
    pub fn render(&self) -> String {
        format!(
            "{} at line {}, column {}\n  {}\n  {}^",
            self.message,
            self.line,
            self.column,
            self.source_line,
            " ".repeat(self.column.saturating_sub(1))
        )
    }
}

impl std::fmt::Display for ExprError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.render())
    }
}

impl std::error::Error for ExprError {}

#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Tok {
    Num(f64),
    Ident(String),
    Op(char),
    LParen,
    RParen,
    Comma,
    End,
}

fn tokenize(src: &str) -> Result<Vec<(Tok, usize)>, ExprError> {
    let b = src.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        let c = b[i];
        if c.is_ascii_whitespace() {
            i += 1;
        } else if c.is_ascii_digit() || (c == b'.' && i + 1 < b.len() && b[i + 1].is_ascii_digit()) {
            let start = i;
            while i < b.len() && (b[i].is_ascii_digit() || b[i] == b'.') {
                i += 1;
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
            let text = &src[start..i];
            let v: f64 = text
                .parse()
                .map_err(|_| ExprError::at(src, start, format!("malformed number '{text}'")))?;
            out.push((Tok::Num(v), start));
        } else if c.is_ascii_alphabetic() || c == b'_' {
            let start = i;
            while i < b.len() && (b[i].is_ascii_alphanumeric() || b[i] == b'_') {
                i += 1;
            }
            out.push((Tok::Ident(src[start..i].to_string()), start));
        } else {
            let tok = match c {
                b'+' | b'-' | b'*' | b'/' | b'^' => Tok::Op(c as char),
                b'(' => Tok::LParen,
                b')' => Tok::RParen,
                b',' => Tok::Comma,
                _ => {
                    let ch = src[i..].chars().next().unwrap_or('?');
                    return Err(ExprError::at(src, i, format!("unexpected character '{ch}'")));
                }
            };
            out.push((tok, i));
            i += 1;
        }
    }
    out.push((Tok::End, src.len()));
    Ok(out)
}

/// Deepest nesting of parentheses, function calls, signs and powers that an expression may
/// have. The parser recurses once per level, so the limit bounds its stack (a few hundred
/// bytes a level); sums and products of any length are parsed by loops, not recursion.
pub const MAX_NESTING: usize = 200;

/// One item of the expression in postfix order (operands before their operator), with the
/// source offset where a name or a call can be reported.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Item {
    Num(f64),
    Name(String, usize),
    Neg,
    Bin(char),
    Call(String, usize, usize),
}

pub(crate) struct Parser<'s> {
    src: &'s str,
    toks: Vec<(Tok, usize)>,
    pos: usize,
    depth: usize,
    out: Vec<Item>,
}

impl<'s> Parser<'s> {
    /// Parses `src` into its items in postfix order.
    pub(crate) fn parse(src: &'s str) -> Result<Vec<Item>, ExprError> {
        let toks = tokenize(src)?;
        let mut p = Parser {
            src,
            toks,
            pos: 0,
            depth: 0,
            out: Vec::new(),
        };
        p.expr()?;
        match p.peek() {
            Tok::End => Ok(p.out),
            t => Err(p.err(format!("expected an operator or the end, found {}", describe(t)))),
        }
    }

    fn peek(&self) -> &Tok {
        self.toks.get(self.pos).map_or(&Tok::End, |t| &t.0)
    }
    fn offset(&self) -> usize {
        self.toks.get(self.pos).map_or(self.src.len(), |t| t.1)
    }
    fn err(&self, msg: String) -> ExprError {
        ExprError::at(self.src, self.offset(), msg)
    }
    fn bump(&mut self) -> Tok {
        let t = self.peek().clone();
        if self.pos + 1 < self.toks.len() {
            self.pos += 1;
        }
        t
    }

    fn expr(&mut self) -> Result<(), ExprError> {
        self.term()?;
        while let Tok::Op(c @ ('+' | '-')) = *self.peek() {
            self.bump();
            self.term()?;
            self.out.push(Item::Bin(c));
        }
        Ok(())
    }

    fn term(&mut self) -> Result<(), ExprError> {
        self.unary()?;
        while let Tok::Op(c @ ('*' | '/')) = *self.peek() {
            self.bump();
            self.unary()?;
            self.out.push(Item::Bin(c));
        }
        Ok(())
    }

    /// Every recursion of the parser passes through here, which counts the nesting.
    fn unary(&mut self) -> Result<(), ExprError> {
        if self.depth >= MAX_NESTING {
            return Err(self.err(format!(
                "the expression is nested deeper than {MAX_NESTING} levels (parentheses, function calls, signs and powers)"
            )));
        }
        self.depth += 1;
        let result = match self.peek() {
            Tok::Op('-') => {
                self.bump();
                self.unary().map(|()| self.out.push(Item::Neg))
            }
            Tok::Op('+') => {
                self.bump();
                self.unary()
            }
            _ => self.power(),
        };
        self.depth -= 1;
        result
    }

    fn power(&mut self) -> Result<(), ExprError> {
        self.primary()?;
        if let Tok::Op('^') = self.peek() {
            self.bump();
            self.unary()?;
            self.out.push(Item::Bin('^'));
        }
        Ok(())
    }

    fn primary(&mut self) -> Result<(), ExprError> {
        let at = self.offset();
        match self.bump() {
            Tok::Num(v) => self.out.push(Item::Num(v)),
            Tok::Ident(name) => {
                if let Tok::LParen = self.peek() {
                    self.bump();
                    let args = self.arguments()?;
                    self.out.push(Item::Call(name, args, at));
                } else {
                    self.out.push(Item::Name(name, at));
                }
            }
            Tok::LParen => {
                self.expr()?;
                match self.peek() {
                    Tok::RParen => {
                        self.bump();
                    }
                    t => return Err(self.err(format!("expected ')', found {}", describe(t)))),
                }
            }
            t => {
                self.pos = self.pos.saturating_sub(usize::from(t != Tok::End));
                return Err(ExprError::at(
                    self.src,
                    at,
                    format!("expected a number, a name or '(', found {}", describe(&t)),
                ));
            }
        }
        Ok(())
    }

    /// The arguments of a call after its '(', through the closing ')'; returns their number.
    fn arguments(&mut self) -> Result<usize, ExprError> {
        let mut args = 0;
        if *self.peek() != Tok::RParen {
            loop {
                self.expr()?;
                args += 1;
                match self.peek() {
                    Tok::Comma => {
                        self.bump();
                    }
                    Tok::RParen => break,
                    t => return Err(self.err(format!("expected ',' or ')', found {}", describe(t)))),
                }
            }
        }
        self.bump();
        Ok(args)
    }
}

fn describe(t: &Tok) -> String {
    match t {
        Tok::Num(v) => format!("the number {v}"),
        Tok::Ident(s) => format!("'{s}'"),
        Tok::Op(c) => format!("'{c}'"),
        Tok::LParen => "'('".into(),
        Tok::RParen => "')'".into(),
        Tok::Comma => "','".into(),
        Tok::End => "the end of the expression".into(),
    }
}
