//! Tokenizer and recursive-descent parser of expressions into a small syntax tree.
//! Precedence, loosest first: `+ -`; `* /`; unary minus; `^` (right associative), so
//! `-x^2 = -(x^2)` and `2^-1 = 0.5`.

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
        let offset = offset.min(source.len());
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
            " ".repeat(self.column - 1)
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

/// A syntax tree node with its source offset.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Ast {
    Num(f64),
    Name(String, usize),
    Neg(Box<Ast>),
    Bin(char, Box<Ast>, Box<Ast>),
    Call(String, Vec<Ast>, usize),
}

pub(crate) struct Parser<'s> {
    src: &'s str,
    toks: Vec<(Tok, usize)>,
    pos: usize,
}

impl<'s> Parser<'s> {
    pub(crate) fn parse(src: &'s str) -> Result<Ast, ExprError> {
        let toks = tokenize(src)?;
        let mut p = Parser { src, toks, pos: 0 };
        let ast = p.expr()?;
        match p.peek() {
            Tok::End => Ok(ast),
            t => Err(p.err(format!("expected an operator or the end, found {}", describe(t)))),
        }
    }

    fn peek(&self) -> &Tok {
        &self.toks[self.pos].0
    }
    fn offset(&self) -> usize {
        self.toks[self.pos].1
    }
    fn err(&self, msg: String) -> ExprError {
        ExprError::at(self.src, self.offset(), msg)
    }
    fn bump(&mut self) -> Tok {
        let t = self.toks[self.pos].0.clone();
        if self.pos + 1 < self.toks.len() {
            self.pos += 1;
        }
        t
    }

    fn expr(&mut self) -> Result<Ast, ExprError> {
        let mut lhs = self.term()?;
        while let Tok::Op(c @ ('+' | '-')) = *self.peek() {
            self.bump();
            let rhs = self.term()?;
            lhs = Ast::Bin(c, Box::new(lhs), Box::new(rhs));
        }
        Ok(lhs)
    }

    fn term(&mut self) -> Result<Ast, ExprError> {
        let mut lhs = self.unary()?;
        while let Tok::Op(c @ ('*' | '/')) = *self.peek() {
            self.bump();
            let rhs = self.unary()?;
            lhs = Ast::Bin(c, Box::new(lhs), Box::new(rhs));
        }
        Ok(lhs)
    }

    fn unary(&mut self) -> Result<Ast, ExprError> {
        match self.peek() {
            Tok::Op('-') => {
                self.bump();
                Ok(Ast::Neg(Box::new(self.unary()?)))
            }
            Tok::Op('+') => {
                self.bump();
                self.unary()
            }
            _ => self.power(),
        }
    }

    fn power(&mut self) -> Result<Ast, ExprError> {
        let base = self.primary()?;
        if let Tok::Op('^') = self.peek() {
            self.bump();
            let exp = self.unary()?;
            return Ok(Ast::Bin('^', Box::new(base), Box::new(exp)));
        }
        Ok(base)
    }

    fn primary(&mut self) -> Result<Ast, ExprError> {
        let at = self.offset();
        match self.bump() {
            Tok::Num(v) => Ok(Ast::Num(v)),
            Tok::Ident(name) => {
                if let Tok::LParen = self.peek() {
                    self.bump();
                    let mut args = Vec::new();
                    if *self.peek() != Tok::RParen {
                        loop {
                            args.push(self.expr()?);
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
                    Ok(Ast::Call(name, args, at))
                } else {
                    Ok(Ast::Name(name, at))
                }
            }
            Tok::LParen => {
                let e = self.expr()?;
                match self.peek() {
                    Tok::RParen => {
                        self.bump();
                        Ok(e)
                    }
                    t => Err(self.err(format!("expected ')', found {}", describe(t)))),
                }
            }
            t => {
                self.pos = self.pos.saturating_sub(usize::from(t != Tok::End));
                Err(ExprError::at(
                    self.src,
                    at,
                    format!("expected a number, a name or '(', found {}", describe(&t)),
                ))
            }
        }
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
